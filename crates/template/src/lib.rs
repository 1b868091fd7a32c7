//! A model crate made from `model.toml` at build time: copy this crate, replace `model.toml`, and rename the
//! `include!`d file and the module to your model's `name`.
//!
//! ```
//! use invsim_model_template::vehicle;
//! use invsim_model_api::InverseModel;
//! // Typed access: steady driving at 20 m/s needs a traction force equal to the driving resistance.
//! let pre = vehicle::Precomputed::new(&vehicle::Params::default());
//! let (x, u) = pre.invert(&[20.0, 0.0], &[], 0.0);
//! assert!((u - 310.0).abs() < 1e-9 && (x[1] - 310.0).abs() < 1e-9);
//! // The runtime's view: the same model behind `InverseModel`.
//! let model = vehicle::Model::default();
//! assert_eq!(model.info().relative_degree, 2);
//! ```
#![deny(clippy::all)]

include!(concat!(env!("OUT_DIR"), "/vehicle.rs"));
