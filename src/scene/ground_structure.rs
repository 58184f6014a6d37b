//! Ground structures: every bar a grid allows (paper Section 3.1).
//!
//! Nodes on an `nx × ny` grid, numbered column-major (column 0 bottom to top, then column
//! 1, …). A bar joins nodes `i < j` when their straight segment holds no third grid node,
//! i.e. when `gcd(|Δcolumn|, |Δrow|) = 1`; overlapping collinear bars are dropped and bars
//! that cross are not connected where they cross. Bars are ordered by `(i, j)`
//! lexicographically ([docs/reference-scenes.md](../../docs/reference-scenes.md)).

/// Grid node `k` as `(column, row)`.
pub fn grid_position(k: usize, ny: usize) -> (usize, usize) {
    (k / ny, k % ny)
}

/// Local coordinates of grid node `(column, row)`: `x ∈ [0, L]`, `y ∈ [−H/2, H/2]`.
pub fn local_coordinates(
    column: usize,
    row: usize,
    nx: usize,
    ny: usize,
    length: f64,
    height: f64,
) -> [f64; 2] {
    let fraction = |i: usize, n: usize| {
        if n > 1 {
            i as f64 / (n - 1) as f64
        } else {
            0.5
        }
    };
    [
        length * fraction(column, nx),
        height * (fraction(row, ny) - 0.5),
    ]
}

/// The bars `(i, j)`, `i < j`, of an `nx × ny` ground structure in lexicographic order.
pub fn bars(nx: usize, ny: usize) -> Vec<(usize, usize)> {
    let n = nx * ny;
    let mut out = Vec::new();
    for i in 0..n {
        for j in i + 1..n {
            let ((ci, ri), (cj, rj)) = (grid_position(i, ny), grid_position(j, ny));
            if gcd(ci.abs_diff(cj), ri.abs_diff(rj)) == 1 {
                out.push((i, j));
            }
        }
    }
    out
}

fn gcd(a: usize, b: usize) -> usize {
    if b == 0 {
        a
    } else {
        gcd(b, a % b)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Brute force: a bar is kept when no third grid node lies on its segment.
    fn bars_by_geometry(nx: usize, ny: usize) -> Vec<(usize, usize)> {
        let n = nx * ny;
        let p = |k: usize| {
            let (c, r) = grid_position(k, ny);
            (c as i64, r as i64)
        };
        let mut out = Vec::new();
        for i in 0..n {
            for j in i + 1..n {
                let ((xi, yi), (xj, yj)) = (p(i), p(j));
                let blocked = (0..n).filter(|&k| k != i && k != j).any(|k| {
                    let (xk, yk) = p(k);
                    let cross = (xj - xi) * (yk - yi) - (yj - yi) * (xk - xi);
                    let within = (xk - xi) * (xk - xj) <= 0 && (yk - yi) * (yk - yj) <= 0;
                    cross == 0 && within
                });
                if !blocked {
                    out.push((i, j));
                }
            }
        }
        out
    }

    #[test]
    fn reference_grid_has_74_bars() {
        assert_eq!(bars(5, 3).len(), 74);
    }

    #[test]
    fn gcd_rule_matches_geometry() {
        for (nx, ny) in [(5, 3), (4, 4), (7, 2), (3, 1), (21, 5)] {
            assert_eq!(bars(nx, ny), bars_by_geometry(nx, ny), "{nx}×{ny}");
        }
    }

    #[test]
    fn nodes_are_column_major_bottom_to_top() {
        assert_eq!(grid_position(4, 3), (1, 1));
        let [x, y] = local_coordinates(1, 0, 5, 3, 1.0, 0.1);
        assert!((x - 0.25).abs() < 1e-15 && (y + 0.05).abs() < 1e-15);
    }
}
