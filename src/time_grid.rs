//! The time grid of a dynamic run: step sizes `hₙ = tₙ₊₁ − tₙ` and the times they reach.
//!
//! The integrator steps through a grid, the responses integrate over it with the
//! trapezoidal rule, and a sensitivity analysis replays it exactly: whether the steps are
//! all equal (a fixed-step run) or vary from step to step, every consumer reads the same
//! `hₙ` and `tₙ`. Times in s.

/// Step sizes and times `t₀ = 0, tₙ₊₁ = tₙ + hₙ` (accumulated in that order, as the
/// integrator does, so that replays reach bitwise the same times).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TimeGrid {
    steps: Vec<f64>,
    times: Vec<f64>,
}

impl TimeGrid {
    /// A grid of the given step sizes from `t = 0`.
    pub fn from_steps(steps: Vec<f64>) -> Self {
        let mut times = Vec::with_capacity(steps.len() + 1);
        let mut t = 0.0;
        times.push(t);
        for h in &steps {
            t += h;
            times.push(t);
        }
        Self { steps, times }
    }

    /// `n` equal steps of `h`.
    pub fn uniform(h: f64, n: usize) -> Self {
        Self::from_steps(vec![h; n])
    }

    /// A single state at `t = 0` (no steps), as for static responses and explicit ones.
    pub fn single() -> Self {
        Self::from_steps(Vec::new())
    }

    /// Number of steps `N`; the states are `0..=N`.
    pub fn len(&self) -> usize {
        self.steps.len()
    }

    /// Whether the grid has no steps (a single state).
    pub fn is_empty(&self) -> bool {
        self.steps.is_empty()
    }

    /// `hₙ`, the step from state `n` to `n + 1`.
    pub fn step(&self, n: usize) -> f64 {
        self.steps[n]
    }

    /// The step sizes.
    pub fn steps(&self) -> &[f64] {
        &self.steps
    }

    /// The times `t₀ … t_N`.
    pub fn times(&self) -> &[f64] {
        &self.times
    }

    /// Duration `t_N − t₀`.
    pub fn duration(&self) -> f64 {
        self.times[self.times.len() - 1] - self.times[0]
    }

    /// Trapezoidal weight of state `n`: `½(hₙ₋₁ + hₙ)`, with `½h₀` and `½h_{N−1}` at the ends
    /// (`0` for a grid without steps).
    pub fn trapezoid(&self, n: usize) -> f64 {
        let before = if n > 0 { self.steps[n - 1] } else { 0.0 };
        let after = self.steps.get(n).copied().unwrap_or(0.0);
        0.5 * (before + after)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn trapezoid_weights_integrate_linear_functions_exactly_on_uneven_steps() {
        let grid = TimeGrid::from_steps(vec![0.1, 0.3, 0.05, 0.55]);
        let integral: f64 = (0..=grid.len())
            .map(|n| grid.trapezoid(n) * (2.0 * grid.times()[n] + 1.0))
            .sum();
        let t = grid.duration();
        assert!((integral - (t * t + t)).abs() < 1e-14);
        assert_eq!(grid.times().len(), 5);
    }
}
