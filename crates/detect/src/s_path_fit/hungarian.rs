//! Minimum-cost assignment (the Hungarian method).
//!
//! Reference: H. W. Kuhn, "The Hungarian method for the assignment problem", Naval Research
//! Logistics Quarterly 2 (1955); J. Munkres, "Algorithms for the assignment and transportation
//! problems", J. SIAM 5 (1957); here in the O(n^2 m) shortest-augmenting-path form with dual
//! potentials (R. Jonker and A. Volgenant, Computing 38, 1987). Written out rather than taken from
//! a crate (`pathfinding::kuhn_munkres` needs integer weights and maximises): 40 lines, no
//! dependency, and the costs stay in pixels.

/// The columns assigned to the rows of `cost` (`rows x cols`, `rows <= cols`, every entry
/// finite) minimising the total cost: each row gets a distinct column.
pub(super) fn min_cost_assignment(cost: &[Vec<f64>]) -> Vec<usize> {
    let n = cost.len();
    let m = cost.first().map_or(0, Vec::len);
    if n == 0 || n > m {
        return Vec::new();
    }
    // 1-based rows and columns; column 0 is the virtual start of each augmenting path.
    let (mut u, mut v) = (vec![0.0; n + 1], vec![0.0; m + 1]);
    let (mut row_of, mut way) = (vec![0usize; m + 1], vec![0usize; m + 1]);
    for i in 1..=n {
        row_of[0] = i;
        let mut j0 = 0;
        let mut min_v = vec![f64::INFINITY; m + 1];
        let mut used = vec![false; m + 1];
        loop {
            used[j0] = true;
            let i0 = row_of[j0];
            let (mut delta, mut j1) = (f64::INFINITY, 0);
            for j in 1..=m {
                if used[j] {
                    continue;
                }
                let cur = cost[i0 - 1][j - 1] - u[i0] - v[j];
                if cur < min_v[j] {
                    min_v[j] = cur;
                    way[j] = j0;
                }
                if min_v[j] < delta {
                    delta = min_v[j];
                    j1 = j;
                }
            }
            for j in 0..=m {
                if used[j] {
                    u[row_of[j]] += delta;
                    v[j] -= delta;
                } else {
                    min_v[j] -= delta;
                }
            }
            j0 = j1;
            if row_of[j0] == 0 {
                break;
            }
        }
        // Flip the augmenting path.
        while j0 != 0 {
            let j1 = way[j0];
            row_of[j0] = row_of[j1];
            j0 = j1;
        }
    }
    let mut col_of = vec![usize::MAX; n];
    for j in 1..=m {
        if row_of[j] != 0 {
            col_of[row_of[j] - 1] = j - 1;
        }
    }
    col_of
}

#[cfg(test)]
mod tests {
    use super::min_cost_assignment;

    #[test]
    fn finds_the_optimum_where_greedy_does_not() {
        // Greedy takes (0, 0) at cost 1 and must then pay 10 for (1, 1): total 11. The optimum
        // crosses over: 2 + 2 = 4.
        let cost = vec![vec![1.0, 2.0, 9.0], vec![2.0, 10.0, 9.0]];
        assert_eq!(min_cost_assignment(&cost), vec![1, 0]);
    }

    #[test]
    fn matches_brute_force_on_small_matrices() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        for _ in 0..50 {
            let cost: Vec<Vec<f64>> = (0..4).map(|_| (0..5).map(|_| rng.random_range(0.0..10.0)).collect()).collect();
            let got = min_cost_assignment(&cost);
            let total = |a: &[usize]| a.iter().enumerate().map(|(i, &j)| cost[i][j]).sum::<f64>();
            let mut best = f64::INFINITY;
            for a in 0..5 {
                for b in (0..5).filter(|&b| b != a) {
                    for c in (0..5).filter(|&c| c != a && c != b) {
                        for d in (0..5).filter(|&d| d != a && d != b && d != c) {
                            best = best.min(total(&[a, b, c, d]));
                        }
                    }
                }
            }
            assert!((total(&got) - best).abs() < 1e-9, "{} vs {best}", total(&got));
        }
    }
}
