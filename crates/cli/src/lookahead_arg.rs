//! `--lookahead A|auto`: a look-ahead in seconds, or `auto` for the longest one that keeps the reference
//! inside the cycle's tolerance band and its cycle energy within 1 % of the trace's
//! (`invsim_runtime::lookahead`).

use std::str::FromStr;

/// The value of `--lookahead`.
#[derive(Copy, Clone, Debug, PartialEq)]
pub enum LookaheadArg {
    Seconds(f64),
    Auto,
}

impl FromStr for LookaheadArg {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        if s.trim().eq_ignore_ascii_case("auto") {
            return Ok(LookaheadArg::Auto);
        }
        crate::number_arg::parse_number(s)
            .map(LookaheadArg::Seconds)
            .map_err(|e| {
                format!(
                    "{}: the look-ahead is a positive, finite number of seconds or `auto`",
                    e.describe(s.trim())
                )
            })
    }
}

impl std::fmt::Display for LookaheadArg {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            LookaheadArg::Seconds(a) => write!(f, "{a}"),
            LookaheadArg::Auto => f.write_str("auto"),
        }
    }
}

/// In the provenance: the number, or the string `auto`.
impl serde::Serialize for LookaheadArg {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            LookaheadArg::Seconds(a) => s.serialize_f64(*a),
            LookaheadArg::Auto => s.serialize_str("auto"),
        }
    }
}

impl LookaheadArg {
    /// The default of `simulate` and `sweep`: 5 s (the interface contract, §3).
    pub const DEFAULT: LookaheadArg =
        LookaheadArg::Seconds(invsim_runtime::inverse::DEFAULT_LOOKAHEAD);

    /// The options builder with this look-ahead.
    pub fn apply(
        self,
        b: invsim_runtime::inverse::SimulationOptionsBuilder,
    ) -> invsim_runtime::inverse::SimulationOptionsBuilder {
        match self {
            LookaheadArg::Seconds(a) => b.lookahead(a),
            LookaheadArg::Auto => b.lookahead_auto(true),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_seconds_and_auto() {
        assert_eq!("2.5".parse(), Ok(LookaheadArg::Seconds(2.5)));
        assert_eq!(" AUTO ".parse(), Ok(LookaheadArg::Auto));
        assert_eq!("-1".parse(), Ok(LookaheadArg::Seconds(-1.0)));
        assert!("fast".parse::<LookaheadArg>().is_err());
        assert!("1e-400".parse::<LookaheadArg>().is_err());
        assert_eq!(LookaheadArg::Auto.to_string(), "auto");
    }
}
