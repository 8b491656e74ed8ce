//! Which table nodes the E(μ) slices and the furnace grid take.

/// Indices of `count` slices of an axis of `n` nodes: both ends and odd interior nodes in between
/// (odd, so that the interior slices fall between the nodes of a LUT taking every other node).
pub fn slice_indices(n: usize, count: usize) -> Vec<usize> {
    if n <= count || count < 2 {
        return (0..n).collect();
    }
    let mut v = vec![0, n - 1];
    for k in 1..count - 1 {
        let t = k as f64 * (n - 1) as f64 / (count - 1) as f64;
        let mut i = t.round() as usize;
        if i.is_multiple_of(2) {
            i = if (t - i as f64) >= 0.0 { i + 1 } else { i - 1 };
        }
        v.push(i.clamp(1, n - 2));
    }
    v.sort_unstable();
    v.dedup();
    v
}

/// Indices of at most `cap` nodes of an axis of `n` (all when n ≤ cap): both ends and odd interior
/// nodes, which a LUT taking every other node does not contain.
pub fn furnace_axis(n: usize, cap: usize) -> Vec<usize> {
    if n <= cap {
        return (0..n).collect();
    }
    slice_indices(n, cap.max(2))
}
#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slices_include_ends_and_odd_interior_nodes() {
        assert_eq!(slice_indices(17, 3), vec![0, 9, 16]);
        assert_eq!(slice_indices(5, 7), vec![0, 1, 2, 3, 4]);
        assert_eq!(furnace_axis(65, 33).len(), 33);
        assert!(furnace_axis(65, 33)[1..32].iter().all(|i| i % 2 == 1));
        assert_eq!(furnace_axis(9, 33), (0..9).collect::<Vec<_>>());
    }
}
