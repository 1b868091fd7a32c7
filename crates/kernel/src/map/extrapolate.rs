//! How a map continues outside its grid: the three extrapolation rules of contract §6 and their names in
//! model files.

/// How a map continues outside its grid (contract §6).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Extrapolate {
    /// The end segments continue (the default).
    Linear,
    /// The edge values are held.
    Clamp,
    /// As `Linear` for the smoothing, but an argument outside the grid at run time is an error
    /// (see `Map::outside`).
    Error,
}

impl Extrapolate {
    /// The rule's name in model files: `linear`, `clamp`, `error`.
    pub fn name(self) -> &'static str {
        match self {
            Extrapolate::Linear => "linear",
            Extrapolate::Clamp => "clamp",
            Extrapolate::Error => "error",
        }
    }

    /// The rule of a name in model files.
    pub fn from_name(name: &str) -> Option<Extrapolate> {
        match name {
            "linear" => Some(Extrapolate::Linear),
            "clamp" => Some(Extrapolate::Clamp),
            "error" => Some(Extrapolate::Error),
            _ => None,
        }
    }
}
