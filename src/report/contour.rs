//! The numbers behind a corner plot's marks: quantiles of a marginal, a smoothed 2-D histogram,
//! the density levels enclosing given posterior mass, and the contour lines at those levels.

/// Mass inside the 1σ and 2σ contours of a 2-D Gaussian: `1 − e^{−k²/2}` for k = 1, 2
/// (39.3 % and 86.5 %), the convention of corner plots (the 2-D analogue of 68 % and 95 %
/// would be the 1σ and 2σ of a 1-D marginal, which a 2-D panel does not show).
pub(crate) const SIGMA_MASS: [f64; 2] = [0.393_469_340_287_366_6, 0.864_664_716_763_387_3];

/// The 16, 50 and 84 % quantiles of the finite `values` (Hyndman–Fan type 7, numpy's default:
/// linear interpolation between order statistics); `None` when no value is finite.
pub(crate) fn quantiles_16_50_84(values: impl IntoIterator<Item = f64>) -> Option<[f64; 3]> {
    let mut v: Vec<f64> = values.into_iter().filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let q = |p: f64| {
        let h = (v.len() - 1) as f64 * p;
        let lo = h.floor() as usize;
        let hi = (lo + 1).min(v.len() - 1);
        v[lo] + (h - lo as f64) * (v[hi] - v[lo])
    };
    Some([q(0.16), q(0.5), q(0.84)])
}

/// `h` (row-major, `ny` rows of `nx`) convolved with a Gaussian of `sigma` bins along both
/// axes, truncated at 3σ. Mass that would fall outside the grid is dropped, as the
/// histogram's range already covers the samples.
pub(crate) fn smooth(h: &[f64], nx: usize, ny: usize, sigma: f64) -> Vec<f64> {
    assert_eq!(h.len(), nx * ny);
    if sigma <= 0.0 {
        return h.to_vec();
    }
    let r = (3.0 * sigma).ceil() as isize;
    let kernel: Vec<f64> = (-r..=r)
        .map(|k| (-0.5 * (k as f64 / sigma).powi(2)).exp())
        .collect();
    let norm: f64 = kernel.iter().sum();
    let kernel: Vec<f64> = kernel.iter().map(|k| k / norm).collect();
    let pass = |src: &[f64], along_x: bool| {
        let mut out = vec![0.0; src.len()];
        for y in 0..ny as isize {
            for x in 0..nx as isize {
                let mut acc = 0.0;
                for (k, w) in kernel.iter().enumerate() {
                    let d = k as isize - r;
                    let (sx, sy) = if along_x { (x + d, y) } else { (x, y + d) };
                    if (0..nx as isize).contains(&sx) && (0..ny as isize).contains(&sy) {
                        acc += w * src[sy as usize * nx + sx as usize];
                    }
                }
                out[y as usize * nx + x as usize] = acc;
            }
        }
        out
    };
    pass(&pass(h, true), false)
}

/// For each mass fraction in `fractions` (each in (0, 1]), the density level `L` such that the
/// cells with density ≥ `L` hold that fraction of the total: the highest-density region. Cells
/// are taken from the densest down; the level is the density of the cell at which the running
/// sum first reaches the fraction. `None` when the total is not positive and finite.
pub(crate) fn hdr_levels(density: &[f64], fractions: &[f64]) -> Option<Vec<f64>> {
    let mut d: Vec<f64> = density
        .iter()
        .copied()
        .filter(|v| v.is_finite() && *v > 0.0)
        .collect();
    let total: f64 = d.iter().sum();
    if !(total > 0.0 && total.is_finite()) {
        return None;
    }
    d.sort_by(|a, b| b.total_cmp(a));
    let mut cum = Vec::with_capacity(d.len());
    let mut acc = 0.0;
    for v in &d {
        acc += v;
        cum.push(acc / total);
    }
    Some(
        fractions
            .iter()
            .map(|&f| {
                let k = cum.partition_point(|&c| c < f).min(d.len() - 1);
                d[k]
            })
            .collect(),
    )
}

/// Line segments of the contour `level` of `z` (row-major, `ny` rows of `nx`) by marching
/// squares, in grid coordinates (`x` = column index, `y` = row index of the cell centres),
/// linearly interpolated along cell edges. Saddle cells are resolved by the mean of the four
/// corners. Values ≥ `level` are inside.
pub(crate) fn contour_segments(
    z: &[f64],
    nx: usize,
    ny: usize,
    level: f64,
) -> Vec<[(f64, f64); 2]> {
    let mut out = Vec::new();
    if nx < 2 || ny < 2 {
        return out;
    }
    let at = |x: usize, y: usize| z[y * nx + x];
    // Where the level crosses the edge from corner a (value va at pa) to b.
    let cross = |pa: (f64, f64), va: f64, pb: (f64, f64), vb: f64| {
        let t = if vb == va {
            0.5
        } else {
            (level - va) / (vb - va)
        };
        (pa.0 + t * (pb.0 - pa.0), pa.1 + t * (pb.1 - pa.1))
    };
    for y in 0..ny - 1 {
        for x in 0..nx - 1 {
            // Corners counter-clockwise from the lower left.
            let p = [
                (x as f64, y as f64),
                (x as f64 + 1.0, y as f64),
                (x as f64 + 1.0, y as f64 + 1.0),
                (x as f64, y as f64 + 1.0),
            ];
            let v = [at(x, y), at(x + 1, y), at(x + 1, y + 1), at(x, y + 1)];
            if v.iter().any(|v| !v.is_finite()) {
                continue;
            }
            let inside = v.map(|v| v >= level);
            let code = inside
                .iter()
                .enumerate()
                .fold(0u8, |c, (k, &i)| c | ((i as u8) << k));
            if code == 0 || code == 15 {
                continue;
            }
            // Crossing point on edge k (from corner k to corner k+1).
            let e = |k: usize| {
                let j = (k + 1) % 4;
                cross(p[k], v[k], p[j], v[j])
            };
            // Edges crossed: those whose ends differ.
            let crossed: Vec<usize> = (0..4)
                .filter(|&k| inside[k] != inside[(k + 1) % 4])
                .collect();
            if crossed.len() == 2 {
                out.push([e(crossed[0]), e(crossed[1])]);
            } else {
                // Saddle: corners 0 and 2 on one side, 1 and 3 on the other.
                let centre_inside = v.iter().sum::<f64>() / 4.0 >= level;
                if centre_inside == inside[0] {
                    // The inside corners connect through the centre: cut off corners 1 and 3.
                    out.push([e(0), e(1)]);
                    out.push([e(2), e(3)]);
                } else {
                    out.push([e(3), e(0)]);
                    out.push([e(1), e(2)]);
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles_match_numpy_and_skip_nan() {
        // numpy.quantile([1, 2, 3, 4, 5], [0.16, 0.5, 0.84]) = [1.64, 3, 4.36]
        let q = quantiles_16_50_84([5.0, f64::NAN, 1.0, 3.0, 2.0, 4.0]).unwrap();
        assert!((q[0] - 1.64).abs() < 1e-12 && q[1] == 3.0 && (q[2] - 4.36).abs() < 1e-12);
        assert_eq!(quantiles_16_50_84([7.0]), Some([7.0; 3]));
        assert_eq!(quantiles_16_50_84([2.0, 2.0, 2.0]), Some([2.0; 3]));
        assert_eq!(quantiles_16_50_84([]), None);
        assert_eq!(quantiles_16_50_84([f64::NAN, f64::INFINITY]), None);
    }

    #[test]
    fn sigma_masses_are_those_of_a_2d_gaussian() {
        assert!((SIGMA_MASS[0] - (1.0 - (-0.5f64).exp())).abs() < 1e-15);
        assert!((SIGMA_MASS[1] - (1.0 - (-2.0f64).exp())).abs() < 1e-15);
    }

    /// A standard 2-D Gaussian sampled on a fine grid: the 39.3 % region is the disc r < 1,
    /// whose edge has density e^{−1/2} of the peak; the 86.5 % one is r < 2, e^{−2}.
    #[test]
    fn hdr_levels_of_a_gaussian_are_at_one_and_two_sigma() {
        let (n, half) = (401, 6.0);
        let step = 2.0 * half / (n - 1) as f64;
        let grid: Vec<f64> = (0..n * n)
            .map(|k| {
                let (x, y) = (-half + (k % n) as f64 * step, -half + (k / n) as f64 * step);
                (-0.5 * (x * x + y * y)).exp()
            })
            .collect();
        let l = hdr_levels(&grid, &SIGMA_MASS).unwrap();
        assert!((l[0] - (-0.5f64).exp()).abs() < 5e-3, "{}", l[0]);
        assert!((l[1] - (-2.0f64).exp()).abs() < 5e-3, "{}", l[1]);
        // Everything, and nothing.
        let all = hdr_levels(&grid, &[1.0]).unwrap()[0];
        assert!(all > 0.0 && all < 1e-7);
        assert_eq!(hdr_levels(&[0.0, 0.0], &[0.5]), None);
        assert_eq!(hdr_levels(&[], &[0.5]), None);
        assert_eq!(hdr_levels(&[f64::NAN, 3.0], &[0.5]), Some(vec![3.0]));
    }

    /// Samples → histogram → smoothing → levels, as the corner plot does: the 1σ contour of a
    /// correlated Gaussian histogram holds 39 % of the samples.
    #[test]
    fn smoothing_keeps_mass_and_the_levels_still_enclose_it() {
        let n = 41;
        let mut h = vec![0.0; n * n];
        h[20 * n + 20] = 1.0;
        let s = smooth(&h, n, n, 1.5);
        assert!((s.iter().sum::<f64>() - 1.0).abs() < 1e-12);
        // A delta becomes a symmetric Gaussian: equal left/right and up/down neighbours.
        assert!((s[20 * n + 19] - s[20 * n + 21]).abs() < 1e-15);
        assert!((s[19 * n + 20] - s[20 * n + 19]).abs() < 1e-15);
        assert!(s[20 * n + 20] > s[20 * n + 21]);
        assert_eq!(smooth(&h, n, n, 0.0), h);
        // A binned Gaussian (σ = 5 bins) smoothed by 1 bin is a Gaussian of σ = √26 bins; its
        // 39.3 % region is still bounded by e^{−1/2} of its peak.
        let g: Vec<f64> = (0..n * n)
            .map(|k| {
                let (x, y) = ((k % n) as f64 - 20.0, (k / n) as f64 - 20.0);
                (-0.5 * (x * x + y * y) / 25.0).exp()
            })
            .collect();
        let s = smooth(&g, n, n, 1.0);
        let peak = s.iter().copied().fold(0.0, f64::max);
        let l = hdr_levels(&s, &SIGMA_MASS).unwrap();
        assert!(
            (l[0] / peak - (-0.5f64).exp()).abs() < 0.03,
            "{}",
            l[0] / peak
        );
    }

    #[test]
    fn contour_of_a_cone_is_a_closed_ring_at_the_right_radius() {
        let n = 21;
        let z: Vec<f64> = (0..n * n)
            .map(|k| {
                let (x, y) = ((k % n) as f64 - 10.0, (k / n) as f64 - 10.0);
                10.0 - (x * x + y * y).sqrt()
            })
            .collect();
        // Level 4.5 (r = 5.5) passes through no grid node.
        let segs = contour_segments(&z, n, n, 4.5);
        assert!(!segs.is_empty());
        for s in &segs {
            for &(x, y) in s {
                let r = ((x - 10.0).powi(2) + (y - 10.0).powi(2)).sqrt();
                assert!((r - 5.5).abs() < 0.05, "r = {r}");
            }
        }
        // Closed: every end point is shared by exactly two segments.
        let key = |p: (f64, f64)| ((p.0 * 1e6).round() as i64, (p.1 * 1e6).round() as i64);
        let mut ends: Vec<_> = segs.iter().flat_map(|s| [key(s[0]), key(s[1])]).collect();
        ends.sort();
        for w in ends.chunks(2) {
            assert_eq!(w[0], w[1]);
        }
        // Nothing above the top, nothing on too small a grid, NaN cells skipped.
        assert!(contour_segments(&z, n, n, 11.0).is_empty());
        assert!(contour_segments(&[1.0], 1, 1, 0.5).is_empty());
        let mut holed = z.clone();
        holed[10 * n + 15] = f64::NAN;
        assert!(contour_segments(&holed, n, n, 4.5).len() < segs.len());
    }

    #[test]
    fn saddle_cells_give_two_segments() {
        // 1 0 / 0 1 with the level between: two crossings pairs.
        let z = [1.0, 0.0, 0.0, 1.0];
        assert_eq!(contour_segments(&z, 2, 2, 0.4).len(), 2);
        assert_eq!(contour_segments(&z, 2, 2, 0.6).len(), 2);
    }
}
