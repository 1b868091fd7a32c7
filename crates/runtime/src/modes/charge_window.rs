//! The battery's state of charge within [0, 1] in a strategy's run: the run starts there (the model file's
//! `initial` or `--initial`) and a chosen run whose charge leaves it is refused. The inverse knows the
//! battery's power, not its contents: an empty battery (SOC = 0) delivers no power and a full one (SOC = 1)
//! takes none, so a run through SOC < 0 or SOC > 1 is not a run the car can drive. (A charge-sustaining
//! ECMS or DP run only gets there from a start near an end; the rules and a given equivalence factor can
//! drain or fill the battery on a long cycle.)

use super::record::Record;
use super::ModalError;

/// The charge's range, as a fraction of the capacity.
const RANGE: (f64, f64) = (0.0, 1.0);

/// Refuse a start charge outside [0, 1]: `soc0` of the state `name`.
pub(super) fn check_start(soc0: f64, name: &str) -> Result<(), ModalError> {
    if (RANGE.0..=RANGE.1).contains(&soc0) {
        return Ok(());
    }
    Err(ModalError::Setup(format!(
        "the battery's start charge {name} = {soc0} is outside [0, 1] (a fraction of the capacity): \
         set it with --initial {name}=VALUE or `initial` in the model file"
    )))
}

/// Refuse a run whose charge (the state column `soc`, named `name`) leaves [0, 1]: the first sample outside,
/// its time and value.
pub(super) fn check_trace(rec: &Record, soc: usize, name: &str) -> Result<(), ModalError> {
    let outside = rec
        .states
        .column(soc)
        .zip(&rec.t)
        .find(|(v, _)| !(RANGE.0..=RANGE.1).contains(v));
    let Some((v, t)) = outside else {
        return Ok(());
    };
    let (end, remedy) = if v < RANGE.0 {
        ("empty", "more charge at the start")
    } else {
        ("full", "less charge at the start")
    };
    Err(ModalError::Setup(format!(
        "the battery's charge {name} leaves [0, 1] at t = {t} s ({name} = {v:.6}): the strategy's run \
         uses a battery beyond {end}, which the car cannot; try {remedy} (--initial {name}=VALUE), a larger \
         battery or, with --equivalence, another equivalence factor"
    )))
}
