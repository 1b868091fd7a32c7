//! Importers of other tools' vehicle files into invsim model files. FASTSim 3 (NREL, Apache-2.0): a
//! conventional or battery-electric vehicle file becomes a model with the vehicle speed as state (and, with
//! FASTSim's engine thermal model, the engine temperature as an internal state: `thermal.rs`), the
//! tractive force at the wheels as input (negative = braking) and FASTSim's energy flows in `[outputs]`, every
//! parameter carrying its unit and a doc naming the FASTSim field it came from. A hybrid (HEV) becomes a model
//! with modes, the battery's charge as a second state and a `[hybrid]` table (`hev.rs`); plug-in hybrids and
//! unknown powertrain types are refused; fields the model does not use are listed as warnings. Every field read is checked against
//! its physical range (`limits.rs`); the file is read through a byte cap (`read.rs`) and its nesting depth is
//! capped before it is parsed (`depth.rs`).

mod battery;
mod bev;
mod chassis;
mod controls;
mod conv;
mod curve;
mod depth;
mod efficiency;
mod error;
mod fastsim;
mod fuel;
mod hev;
mod hev_rules;
mod limits;
mod locate;
mod model;
mod read;
mod thermal;
mod unsupported;
mod yaml;

pub use chassis::{AIR_DENSITY, GRAVITY};
pub use depth::MAX_YAML_DEPTH;
pub use error::ImportError;
pub use fastsim::{import_fastsim, Imported, Powertrain};
pub use limits::{describe as describe_range, Range, FIELDS as FIELD_RANGES};
pub use read::{read_vehicle_file, MAX_VEHICLE_FILE_BYTES};
pub use yaml::lookup as yaml_lookup;
pub use yaml::parse as parse_yaml;
