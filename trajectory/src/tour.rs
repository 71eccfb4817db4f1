//! The order in which to visit a set of rest-to-rest targets for the least total move time.
//!
//! A static pose pattern is a set, not a sequence: the estimate does not depend on the order,
//! but the robot time does (a move's duration follows from the largest joint distance). The
//! tour starts and ends at `start`; with `revisit_first` it returns to its first target before
//! going home (the revisit that measures drift). Up to [`EXACT_UP_TO`] targets the tour is the
//! exact optimum (Held–Karp dynamic programming over subsets, for every choice of the first
//! target); above, nearest neighbour improved by 2-opt exchanges.

/// Largest number of targets ordered exactly (12 → 12 · 2¹² · 12² ≈ 7·10⁶ steps).
pub const EXACT_UP_TO: usize = 12;

/// Indices of `targets` in visiting order. `cost(a, b)` is the move time from a to b (s); it
/// must be finite and non-negative.
pub fn order<T>(
    start: &T,
    targets: &[T],
    revisit_first: bool,
    cost: impl Fn(&T, &T) -> f64,
) -> Vec<usize> {
    let n = targets.len();
    if n <= 1 {
        return (0..n).collect();
    }
    // c[i][j]: between targets; out[i]: start → i; home[i]: i → start.
    let c: Vec<Vec<f64>> = targets
        .iter()
        .map(|a| targets.iter().map(|b| cost(a, b)).collect())
        .collect();
    let out: Vec<f64> = targets.iter().map(|t| cost(start, t)).collect();
    let home: Vec<f64> = targets.iter().map(|t| cost(t, start)).collect();
    // the way back from the last target, through the first when revisiting
    let back = |first: usize, last: usize| {
        if revisit_first {
            c[last][first] + home[first]
        } else {
            home[last]
        }
    };
    if n <= EXACT_UP_TO {
        exact(n, &c, &out, &back)
    } else {
        improved(n, &c, &out, &back)
    }
}

/// Total move time of a visiting order (s), including the way out and back.
pub fn duration<T>(
    start: &T,
    targets: &[T],
    order: &[usize],
    revisit_first: bool,
    cost: impl Fn(&T, &T) -> f64,
) -> f64 {
    let (Some(&first), Some(&last)) = (order.first(), order.last()) else {
        return 0.0;
    };
    let inner: f64 = order
        .windows(2)
        .map(|w| cost(&targets[w[0]], &targets[w[1]]))
        .sum();
    let back = if revisit_first {
        cost(&targets[last], &targets[first]) + cost(&targets[first], start)
    } else {
        cost(&targets[last], start)
    };
    cost(start, &targets[first]) + inner + back
}

fn exact(n: usize, c: &[Vec<f64>], out: &[f64], back: &dyn Fn(usize, usize) -> f64) -> Vec<usize> {
    let full = (1usize << n) - 1;
    let mut best = (f64::INFINITY, Vec::new());
    // dp[set][last]: least time from `first` through `set` ending at `last`
    let mut dp = vec![f64::INFINITY; (full + 1) * n];
    let mut from = vec![usize::MAX; (full + 1) * n];
    for first in 0..n {
        dp.fill(f64::INFINITY);
        dp[(1 << first) * n + first] = out[first];
        for set in 1..=full {
            if set & (1 << first) == 0 {
                continue;
            }
            for last in 0..n {
                let here = dp[set * n + last];
                if !here.is_finite() {
                    continue;
                }
                for (next, step) in c[last].iter().enumerate() {
                    if set & (1 << next) != 0 {
                        continue;
                    }
                    let key = (set | 1 << next) * n + next;
                    let t = here + step;
                    if t < dp[key] {
                        dp[key] = t;
                        from[key] = last;
                    }
                }
            }
        }
        for last in 0..n {
            let t = dp[full * n + last] + back(first, last);
            if t < best.0 {
                let mut path = Vec::with_capacity(n);
                let (mut set, mut at) = (full, last);
                while at != usize::MAX {
                    path.push(at);
                    let prev = from[set * n + at];
                    set &= !(1 << at);
                    at = if set == 0 { usize::MAX } else { prev };
                }
                path.reverse();
                best = (t, path);
            }
        }
    }
    best.1
}

fn improved(
    n: usize,
    c: &[Vec<f64>],
    out: &[f64],
    back: &dyn Fn(usize, usize) -> f64,
) -> Vec<usize> {
    let total = |p: &[usize]| {
        out[p[0]] + p.windows(2).map(|w| c[w[0]][w[1]]).sum::<f64>() + back(p[0], p[n - 1])
    };
    let mut first = 0;
    for i in 1..n {
        if out[i] < out[first] {
            first = i;
        }
    }
    let mut path = vec![first];
    let mut left: Vec<usize> = (0..n).filter(|&i| i != first).collect();
    while !left.is_empty() {
        let at = path[path.len() - 1];
        let (k, _) = left
            .iter()
            .enumerate()
            .fold((0, f64::INFINITY), |b, (k, &i)| {
                if c[at][i] < b.1 { (k, c[at][i]) } else { b }
            });
        path.push(left.swap_remove(k));
    }
    let mut cost = total(&path);
    loop {
        let mut better = false;
        for i in 0..n - 1 {
            for j in i + 1..n {
                path[i..=j].reverse();
                let t = total(&path);
                if t + 1e-12 < cost {
                    cost = t;
                    better = true;
                } else {
                    path[i..=j].reverse();
                }
            }
        }
        if !better {
            return path;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn chebyshev(a: &[f64; 2], b: &[f64; 2]) -> f64 {
        (a[0] - b[0]).abs().max((a[1] - b[1]).abs())
    }

    fn brute_force(start: &[f64; 2], t: &[[f64; 2]], revisit: bool) -> f64 {
        fn perms(v: Vec<usize>) -> Vec<Vec<usize>> {
            if v.len() <= 1 {
                return vec![v];
            }
            let mut out = Vec::new();
            for i in 0..v.len() {
                let mut rest = v.clone();
                let x = rest.remove(i);
                for mut p in perms(rest) {
                    p.insert(0, x);
                    out.push(p);
                }
            }
            out
        }
        perms((0..t.len()).collect())
            .iter()
            .map(|p| duration(start, t, p, revisit, chebyshev))
            .fold(f64::INFINITY, f64::min)
    }

    fn points(n: usize, seed: u64) -> Vec<[f64; 2]> {
        let mut x = seed;
        let mut next = || {
            x = x
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (x >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        (0..n).map(|_| [next(), next()]).collect()
    }

    #[test]
    fn the_exact_order_is_the_brute_force_optimum() {
        for seed in 1..6 {
            for revisit in [false, true] {
                let t = points(7, seed);
                let o = order(&[0.0, 0.0], &t, revisit, chebyshev);
                let mut sorted = o.clone();
                sorted.sort_unstable();
                assert_eq!(sorted, (0..7).collect::<Vec<_>>());
                let got = duration(&[0.0, 0.0], &t, &o, revisit, chebyshev);
                let best = brute_force(&[0.0, 0.0], &t, revisit);
                assert!((got - best).abs() < 1e-12, "seed {seed}: {got} vs {best}");
            }
        }
    }

    #[test]
    fn a_large_set_is_visited_once_and_no_worse_than_as_given() {
        let t = points(30, 9);
        let o = order(&[0.0, 0.0], &t, true, chebyshev);
        let mut sorted = o.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, (0..30).collect::<Vec<_>>());
        let given: Vec<usize> = (0..30).collect();
        let d = |o: &[usize]| duration(&[0.0, 0.0], &t, o, true, chebyshev);
        assert!(d(&o) < 0.6 * d(&given), "{} vs {}", d(&o), d(&given));
    }

    #[test]
    fn trivial_sets() {
        let c = |a: &f64, b: &f64| (a - b).abs();
        assert!(order(&0.0, &[], false, c).is_empty());
        assert_eq!(order(&0.0, &[3.0], true, c), vec![0]);
        assert_eq!(duration(&0.0, &[3.0], &[0], true, c), 6.0);
    }
}
