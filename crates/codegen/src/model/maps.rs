//! Lookup maps in the generated module (contract §6): each map's grid and values as static data, the
//! `Precomputed::maps` they are built into (replaceable at run time: `InverseModel::set_map`, `--map`), and
//! the trait method. A model without maps gets none of this, so its generated code is unchanged.
//!
//! Calls are emitted as `self.maps[m].partial(&[a, b], [I, J])` (see `emit::map_call`), or, where a function
//! calls one map at the same arguments more than once, read from one `self.maps[m].partials2(&[a, b])`
//! (`emit::map_bundles`): the value and the partial derivatives from one pass over the corners in the window.

use super::context::Gen;
use proc_macro2::{Literal, TokenStream};
use quote::{format_ident, quote};

/// What a model with maps adds: items at module level, the `Precomputed` field, its initialiser from
/// `default_maps()`, and the `maps` and `set_map` methods of the trait impl.
pub(super) struct MapTokens {
    pub(super) items: TokenStream,
    pub(super) field: TokenStream,
    pub(super) init: TokenStream,
    pub(super) trait_method: TokenStream,
}

fn floats(values: &[f64]) -> TokenStream {
    let lits = values.iter().map(|&v| Literal::f64_suffixed(v));
    quote!([#(#lits),*])
}

/// `None` for a model without maps.
pub(super) fn map_tokens(g: &Gen<'_>) -> Option<MapTokens> {
    let maps = g.pool.maps();
    if maps.is_empty() {
        return None;
    }
    let mut statics = Vec::new();
    let mut builds = Vec::new();
    for (i, m) in maps.iter().enumerate() {
        let d = &m.data;
        let s = d.settings();
        let (xs, vs) = (
            format_ident!("MAP{}_X", i),
            format_ident!("MAP{}_VALUES", i),
        );
        let (x, v) = (floats(d.x()), floats(d.values()));
        let (nx, nv) = (d.x().len(), d.values().len());
        statics.push(quote!(static #xs: [f64; #nx] = #x; static #vs: [f64; #nv] = #v;));
        let smooth = Literal::f64_suffixed(s.smooth);
        let extrapolate = format_ident!("{}", format!("{:?}", s.extrapolate));
        let interp = format_ident!("{}", format!("{:?}", s.interp));
        let settings = quote!(MapSettings { smooth: #smooth, extrapolate: Extrapolate::#extrapolate, interp: Interp::#interp });
        let name = &m.name;
        let build = match d.y() {
            Some(y) => {
                let ys = format_ident!("MAP{}_Y", i);
                let (yv, ny) = (floats(y), y.len());
                statics.push(quote!(static #ys: [f64; #ny] = #yv;));
                quote!(Map::new_2d(#xs.to_vec(), #ys.to_vec(), #vs.to_vec(), #settings))
            }
            None => quote!(Map::new_1d(#xs.to_vec(), #vs.to_vec(), #settings)),
        };
        builds.push(
            quote!(#build.expect("the map was checked when the model file was read").named(#name)),
        );
    }
    let names = maps.iter().map(|m| m.name.as_str());
    let k = maps.len();
    let items = quote! {
        #(#statics)*
        /// The lookup maps' names, in `Precomputed::maps` order.
        pub const MAP_NAMES: [&str; #k] = [#(#names),*];
        /// The maps with the model file's grids and values.
        pub fn default_maps() -> Vec<Map> {
            use invsim_model_api::map::{Extrapolate, Interp, MapSettings};
            vec![#(#builds),*]
        }
    };
    let _ = g;
    Some(MapTokens {
        items,
        field: quote!(pub maps: Vec<Map>,),
        init: quote!(maps: default_maps(),),
        trait_method: quote! {
            fn maps(&self) -> &[Map] {
                &self.pre.maps
            }
            fn set_map(
                &mut self,
                name: &str,
                data: (&[f64], Option<&[f64]>, &[f64]),
            ) -> Result<(), ModelError> {
                invsim_model_api::set_map_checked(&mut self.pre.maps, &MAP_NAMES, name, data)
            }
        },
    })
}
