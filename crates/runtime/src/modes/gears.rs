//! The gear along the run: up- and downshift speeds with hysteresis on the smoothed cycle speed, the
//! regulation's prescription for a 5-speed manual car on the ECE-15 / EUDC / NEDC (UNECE R83 Annex 4a,
//! 70/220/EEC as amended by 91/441/EEC: the gear of each operation of the elementary urban cycle and of the
//! extra-urban cycle), or a gear column of the cycle file.

use std::path::Path;

/// Where the gear comes from.
#[derive(Debug, Clone, PartialEq)]
pub enum GearSource {
    /// No gearbox: gear 1 throughout.
    Fixed,
    /// Shift from gear k to k+1 above `up[k-1]`, from k+1 to k below `down[k-1]` (m/s of the smoothed cycle).
    Speed { up: Vec<f64>, down: Vec<f64> },
    /// A gear per time (piecewise constant from each row's time on), from the regulation or the cycle file.
    Table(Vec<(f64, usize)>),
}

/// ECE-15: (start time s, gear) of each operation, gear 1 also for idle phases (the car stands; the
/// standstill mode decides the clutch).
const ECE15_GEARS: &[(f64, usize)] = &[
    (0.0, 1),
    (54.0, 2),
    (96.0, 1),
    (124.0, 2),
    (135.0, 3),
    (176.0, 2),
    (188.0, 1),
];

/// EUDC for a 5-speed gearbox: 70 km/h and above in 5th, 50 km/h in 4th.
const EUDC_GEARS: &[(f64, usize)] = &[
    (0.0, 1),
    (25.0, 2),
    (36.0, 3),
    (46.0, 4),
    (61.0, 5),
    (111.0, 4),
    (201.0, 5),
];

/// The regulation's gear table for a built-in cycle (`ece`, `eudc`, `nedc`), if it has one.
pub fn regulation_table(cycle: &str) -> Option<Vec<(f64, usize)>> {
    let parts: Vec<(f64, &[(f64, usize)])> = match cycle {
        "ece" => vec![(0.0, ECE15_GEARS)],
        "eudc" => vec![(0.0, EUDC_GEARS)],
        "nedc" => vec![
            (0.0, ECE15_GEARS),
            (195.0, ECE15_GEARS),
            (390.0, ECE15_GEARS),
            (585.0, ECE15_GEARS),
            (780.0, EUDC_GEARS),
        ],
        _ => return None,
    };
    Some(
        parts
            .iter()
            .flat_map(|(t0, rows)| rows.iter().map(move |(t, g)| (t0 + t, *g)))
            .collect(),
    )
}

/// The gear column `column` of a cycle CSV file: (time, gear) per row; 0 or an empty cell is gear 1.
pub fn column_table(path: &Path, column: &str) -> Result<Vec<(f64, usize)>, String> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    let text = text.trim_start_matches('\u{feff}');
    let mut rdr = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .from_reader(text.as_bytes());
    let headers = rdr.headers().map_err(|e| e.to_string())?.clone();
    let find = |names: &[&str]| headers.iter().position(|h| names.contains(&h));
    let tcol = find(crate::cycle::TIME_COLUMNS).ok_or("no time column")?;
    let gcol =
        find(&[column]).ok_or_else(|| format!("the cycle file has no gear column `{column}`"))?;
    let mut out = Vec::new();
    for (i, row) in rdr.records().enumerate() {
        let row = row.map_err(|e| e.to_string())?;
        let line = i + 2;
        let t: f64 = row
            .get(tcol)
            .unwrap_or("")
            .parse()
            .map_err(|_| format!("line {line}: bad time"))?;
        let cell = row.get(gcol).unwrap_or("");
        let g = if cell.is_empty() {
            1.0
        } else {
            cell.parse::<f64>()
                .map_err(|_| format!("line {line}: gear `{cell}` is not a number"))?
        };
        if !(g.is_finite() && g >= 0.0 && g.fract() == 0.0) {
            return Err(format!("line {line}: gear {g} is not a whole number ≥ 0"));
        }
        out.push((t, (g as usize).max(1)));
    }
    Ok(out)
}

/// The gear state machine over the run.
#[derive(Debug, Clone)]
pub struct GearBox {
    source: GearSource,
    gears: usize,
    gear: usize,
}

impl GearBox {
    pub fn new(source: GearSource, gears: usize) -> GearBox {
        GearBox {
            source,
            gears: gears.max(1),
            gear: 0,
        }
    }

    /// The gear at time `t` with smoothed cycle speed `v` (call in increasing t).
    pub fn gear(&mut self, t: f64, v: f64) -> usize {
        match &self.source {
            GearSource::Fixed => self.gear = 1,
            GearSource::Table(rows) => {
                let g = rows
                    .iter()
                    .take_while(|(tr, _)| *tr <= t)
                    .last()
                    .map_or(1, |(_, g)| *g);
                self.gear = g.clamp(1, self.gears);
            }
            GearSource::Speed { up, down } => {
                if self.gear == 0 {
                    // The start: the gear whose band holds v (the lowest whose upshift speed is above v).
                    self.gear = 1 + up.iter().take_while(|&&u| v > u).count();
                }
                while self.gear < self.gears && v > up[self.gear - 1] {
                    self.gear += 1;
                }
                while self.gear > 1 && v < down[self.gear - 2] {
                    self.gear -= 1;
                }
            }
        }
        self.gear
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hysteresis() {
        let mut g = GearBox::new(
            GearSource::Speed {
                up: vec![5.0, 10.0],
                down: vec![3.0, 8.0],
            },
            3,
        );
        assert_eq!(g.gear(0.0, 0.0), 1);
        assert_eq!(g.gear(1.0, 6.0), 2);
        assert_eq!(g.gear(2.0, 4.0), 2);
        assert_eq!(g.gear(3.0, 2.0), 1);
        assert_eq!(g.gear(4.0, 11.0), 3);
    }

    #[test]
    fn regulation_nedc() {
        let t = regulation_table("nedc").expect("nedc has a table");
        let mut g = GearBox::new(GearSource::Table(t), 5);
        assert_eq!(g.gear(70.0, 0.0), 2);
        assert_eq!(g.gear(780.0 + 300.0, 0.0), 5);
        assert_eq!(g.gear(780.0 + 150.0, 0.0), 4);
    }
}
