//! The parts every FASTSim vehicle shares: mass (FASTSim's total, glider, cargo and powertrain), the wheels'
//! rotating inertia, road load (drag, rolling resistance, grade) and the auxiliary load; and FASTSim's physical
//! constants.

use crate::error::ImportError;
use crate::model::Model;
use crate::yaml::Doc;

/// Air density FASTSim uses in its drag power (kg/m³): its standard-atmosphere value at its default
/// elevation, the same on every cycle (FASTSim 3.1 `Air::get_density(None, None)`; its history field
/// `air_density_kilograms_per_cubic_meter` reports 1.2, but the drag power it books uses this value).
pub const AIR_DENSITY: f64 = 1.17285;
/// FASTSim's gravitational acceleration (m/s²), `uc::ACC_GRAV`.
pub const GRAVITY: f64 = 9.8;

/// Emit the chassis parameters (each checked against its range in `limits.rs` by `Model::field`) and the
/// road-load definitions:
/// m_eff = m + n_w J_w / r_w² (FASTSim books the wheels' kinetic energy ½ n_w J_w (v/r_w)² as its own power
/// term), F_res = ½ ρ C_d A v² + m g (c_r cos(atan(grade)) + grade) (FASTSim's drag, rolling and ascent
/// powers divided by the speed: it takes the ascent as g · grade, not g · sin(atan(grade))).
pub fn emit(doc: &Doc, model: &mut Model) -> Result<(), ImportError> {
    let mass = doc.opt_num("mass_kilograms")?.filter(|m| m.is_finite());
    let Some(mass) = mass else {
        return Err(ImportError::field(
            "mass_kilograms",
            "missing or NaN: the vehicle's total mass must be set (FASTSim derives it when the file is \
             loaded; export the file with `fastsim.Vehicle.from_file(...).to_yaml()`)",
        ));
    };
    model.field(
        "m",
        mass,
        "kg",
        "vehicle mass (glider, cargo and powertrain)",
        "mass_kilograms",
    )?;
    let c = |f: &str| format!("chassis.{f}");
    model.field(
        "J_w",
        doc.num(&c("wheel_inertia_kilogram_square_meters"))?,
        "kg m^2",
        "rotating inertia of one wheel",
        &c("wheel_inertia_kilogram_square_meters"),
    )?;
    model.field(
        "n_w",
        doc.num(&c("num_wheels"))?,
        "-",
        "number of wheels",
        &c("num_wheels"),
    )?;
    model.field(
        "r_w",
        doc.num(&c("wheel_radius_meters"))?,
        "m",
        "wheel radius",
        &c("wheel_radius_meters"),
    )?;
    model.field(
        "C_d",
        doc.num(&c("drag_coef"))?,
        "-",
        "aerodynamic drag coefficient",
        &c("drag_coef"),
    )?;
    model.field(
        "A_f",
        doc.num(&c("frontal_area_square_meters"))?,
        "m^2",
        "frontal area",
        &c("frontal_area_square_meters"),
    )?;
    model.field(
        "c_r",
        doc.num(&c("wheel_rr_coef"))?,
        "-",
        "rolling resistance coefficient",
        &c("wheel_rr_coef"),
    )?;
    model.field(
        "P_aux",
        doc.num("pwr_aux_base_watts")?,
        "W",
        "auxiliary (electrical) load",
        "pwr_aux_base_watts",
    )?;
    model.constant("rho_a", AIR_DENSITY, "kg/m^3", "air density; FASTSim's constant (Air::get_density at its default elevation), not a field of the vehicle file");
    model.constant("g_0", GRAVITY, "m/s^2", "gravitational acceleration; FASTSim's constant uc::ACC_GRAV, not a field of the vehicle file");
    model.def("m_eff", "m + n_w*J_w/r_w^2", "kg", "vehicle mass with the wheels' rotating inertia (FASTSim's wheel-inertia power 0.5 n_w J_w d(v/r_w)^2/dt)");
    model.def(
        "F_res",
        "0.5*rho_a*C_d*A_f*v^2 + m*g_0*(c_r*cos(atan(grade)) + grade)",
        "N",
        "road load: drag, rolling resistance and ascent as FASTSim books them (ascent m g grade)",
    );
    model.def(
        "P_w",
        "F_t*v",
        "W",
        "tractive power at the wheels (FASTSim `pwr_tractive`), negative when braking",
    );
    for f in [
        "glider_mass_kilograms",
        "cargo_mass_kilograms",
        "mass_kilograms",
    ] {
        doc.mark(&c(f));
    }
    Ok(())
}
