//! Applied nodal loads: forces and moments, constant or scaled by a time table.

use crate::error::SceneError;

/// A time history `g(t)` scaling a load.
#[derive(Debug, Clone, PartialEq)]
pub enum TimeFunction {
    /// `g(t) = 1`.
    Constant,
    /// Piecewise-linear through `(tᵢ, gᵢ)`, held constant outside the table.
    Table {
        /// Sample times, strictly increasing.
        t: Vec<f64>,
        /// Sample values.
        value: Vec<f64>,
    },
}

impl TimeFunction {
    /// Sample times of a table, where the load's rate jumps (none for a constant).
    pub fn kinks(&self) -> Vec<f64> {
        match self {
            Self::Constant => Vec::new(),
            Self::Table { t, .. } => t.clone(),
        }
    }

    /// `g(t)`.
    pub fn at(&self, time: f64) -> f64 {
        match self {
            Self::Constant => 1.0,
            Self::Table { t, value } => {
                let n = t.len();
                if time <= t[0] {
                    return value[0];
                }
                if time >= t[n - 1] {
                    return value[n - 1];
                }
                let k = t.partition_point(|&tk| tk <= time) - 1;
                let w = (time - t[k]) / (t[k + 1] - t[k]);
                (1.0 - w) * value[k] + w * value[k + 1]
            }
        }
    }
}

/// Force `(F_x, F_y)` (N) and moment `M` (N m) on a node, scaled by `g(t)`.
#[derive(Debug, Clone, PartialEq)]
pub struct NodalLoad {
    /// Node index.
    pub node: usize,
    /// `[F_x, F_y, M]` at `g = 1`.
    pub value: [f64; 3],
    /// Time scaling.
    pub time: TimeFunction,
}

/// Samples `(t_k, v_k)` of a time history: at least two, as many `what` as times, all
/// finite, times strictly increasing.
pub(crate) fn samples(path: &str, t: &[f64], values: &[f64], what: &str) -> Result<(), SceneError> {
    if t.len() < 2 || t.len() != values.len() {
        return Err(SceneError::new(
            path,
            format!(
                "needs at least two samples and as many {what} as times ({} vs {})",
                values.len(),
                t.len()
            ),
        ));
    }
    for (k, (&ti, &vi)) in t.iter().zip(values).enumerate() {
        for (name, v) in [
            (format!("{path}.t[{k}]"), ti),
            (format!("{path}.{what}[{k}]"), vi),
        ] {
            if !v.is_finite() {
                return Err(SceneError::new(name, format!("must be finite, got {v}")));
            }
        }
    }
    if let Some(k) = t.windows(2).position(|w| w[1] <= w[0]) {
        return Err(SceneError::new(
            format!("{path}.t[{}]", k + 1),
            "times must be strictly increasing",
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_interpolates_linearly_and_holds_outside() {
        let g = TimeFunction::Table {
            t: vec![0.0, 1.0, 3.0],
            value: vec![0.0, 2.0, -2.0],
        };
        assert_eq!(g.at(-1.0), 0.0);
        assert!((g.at(0.25) - 0.5).abs() < 1e-15);
        assert!((g.at(2.0) - 0.0).abs() < 1e-15);
        assert_eq!(g.at(9.0), -2.0);
        assert_eq!(TimeFunction::Constant.at(3.0), 1.0);
    }
}
