//! Balanced clustering of surface samples (position + weighted normal) into B groups: recursive
//! median bisection along the principal axis for equal sizes, then a few Lloyd (k-means)
//! iterations so the groups become compact, round patches.

#![allow(clippy::needless_range_loop)] // xyz loops read better indexed

/// Splits the samples `idx` (indices into `pos`/`nrm`) into at most `b` non-empty groups.
/// `normal_weight` (length units) scales the normals in the feature `(p, w n)`, so surfaces
/// facing away from each other (two sides of a thin part) fall into different groups.
/// Deterministic.
pub(super) fn split(
    pos: &[[f64; 3]],
    nrm: &[[f64; 3]],
    idx: &[u32],
    b: usize,
    normal_weight: f64,
    lloyd_iters: usize,
) -> Vec<Vec<u32>> {
    if idx.is_empty() {
        return Vec::new();
    }
    if idx.len() <= b {
        return idx.iter().map(|&i| vec![i]).collect();
    }
    let feat = |i: u32| -> [f64; 6] {
        let p = pos[i as usize];
        let n = nrm[i as usize];
        [
            p[0],
            p[1],
            p[2],
            normal_weight * n[0],
            normal_weight * n[1],
            normal_weight * n[2],
        ]
    };
    let mut groups: Vec<Vec<u32>> = Vec::with_capacity(b);
    bisect(idx.to_vec(), b, &feat, &mut groups);
    for _ in 0..lloyd_iters {
        let cents: Vec<[f64; 6]> = groups.iter().map(|g| mean(g, &feat)).collect();
        let mut next: Vec<Vec<u32>> = vec![Vec::new(); groups.len()];
        for &i in idx {
            let f = feat(i);
            let mut best = 0;
            let mut bd = f64::INFINITY;
            for (j, c) in cents.iter().enumerate() {
                let d = d2(&f, c);
                if d < bd {
                    bd = d;
                    best = j;
                }
            }
            next[best].push(i);
        }
        next.retain(|g| !g.is_empty());
        groups = next;
    }
    groups
}

fn bisect(idx: Vec<u32>, k: usize, feat: &dyn Fn(u32) -> [f64; 6], out: &mut Vec<Vec<u32>>) {
    if k <= 1 || idx.len() <= 1 {
        out.push(idx);
        return;
    }
    let m = mean(&idx, feat);
    let axis = principal_axis(&idx, feat, &m);
    let mut keyed: Vec<(f64, u32)> = idx
        .iter()
        .map(|&i| {
            let f = feat(i);
            let mut s = 0.0;
            for a in 0..6 {
                s += (f[a] - m[a]) * axis[a];
            }
            (s, i)
        })
        .collect();
    let k1 = k / 2;
    let cut = (idx.len() * k1 / k).clamp(1, idx.len() - 1);
    keyed.select_nth_unstable_by(cut, |a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    let right: Vec<u32> = keyed[cut..].iter().map(|x| x.1).collect();
    let left: Vec<u32> = keyed[..cut].iter().map(|x| x.1).collect();
    bisect(left, k1, feat, out);
    bisect(right, k - k1, feat, out);
}

fn mean(idx: &[u32], feat: &dyn Fn(u32) -> [f64; 6]) -> [f64; 6] {
    let mut m = [0.0; 6];
    for &i in idx {
        let f = feat(i);
        for a in 0..6 {
            m[a] += f[a];
        }
    }
    let n = idx.len().max(1) as f64;
    m.map(|x| x / n)
}

/// Dominant eigenvector of the features' covariance (power iteration, deterministic start
/// on the coordinate of largest variance).
fn principal_axis(idx: &[u32], feat: &dyn Fn(u32) -> [f64; 6], m: &[f64; 6]) -> [f64; 6] {
    let mut cov = [[0.0; 6]; 6];
    for &i in idx {
        let f = feat(i);
        let d: [f64; 6] = std::array::from_fn(|a| f[a] - m[a]);
        for a in 0..6 {
            for c in 0..6 {
                cov[a][c] += d[a] * d[c];
            }
        }
    }
    let start = (0..6)
        .max_by(|&a, &b| cov[a][a].total_cmp(&cov[b][b]))
        .unwrap_or(0);
    let mut v = [0.0; 6];
    v[start] = 1.0;
    for _ in 0..40 {
        let mut w = [0.0; 6];
        for a in 0..6 {
            for c in 0..6 {
                w[a] += cov[a][c] * v[c];
            }
        }
        let n = w.iter().map(|x| x * x).sum::<f64>().sqrt();
        if n <= 0.0 || !n.is_finite() {
            break;
        }
        v = w.map(|x| x / n);
    }
    v
}

#[inline]
fn d2(a: &[f64; 6], b: &[f64; 6]) -> f64 {
    let mut s = 0.0;
    for k in 0..6 {
        s += (a[k] - b[k]) * (a[k] - b[k]);
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn splits_a_line_into_balanced_contiguous_groups() {
        let pos: Vec<[f64; 3]> = (0..800).map(|i| [i as f64, 0.0, 0.0]).collect();
        let nrm = vec![[0.0, 0.0, 1.0]; 800];
        let idx: Vec<u32> = (0..800).collect();
        let g = split(&pos, &nrm, &idx, 8, 1.0, 3);
        assert_eq!(g.len(), 8);
        let mut all: Vec<u32> = g.concat();
        all.sort();
        assert_eq!(all, idx);
        for grp in &g {
            assert_eq!(grp.len(), 100);
            let lo = grp.iter().min().unwrap();
            let hi = grp.iter().max().unwrap();
            assert_eq!(hi - lo, 99, "contiguous");
        }
        assert_eq!(split(&pos, &nrm, &idx[..3], 8, 1.0, 3).len(), 3);
    }

    #[test]
    fn opposite_normals_separate_close_points() {
        // Two sheets 1 apart with opposite normals, 100 wide: a 2-split by a strong normal
        // weight separates the sheets, not the halves.
        let mut pos = Vec::new();
        let mut nrm = Vec::new();
        for i in 0..200 {
            let x = (i % 100) as f64;
            let z = if i < 100 { 0.0 } else { 1.0 };
            pos.push([x, 0.0, z]);
            nrm.push([0.0, 0.0, if i < 100 { -1.0 } else { 1.0 }]);
        }
        let idx: Vec<u32> = (0..200).collect();
        let g = split(&pos, &nrm, &idx, 2, 200.0, 2);
        assert_eq!(g.len(), 2);
        for grp in &g {
            let z0 = pos[grp[0] as usize][2];
            assert!(grp.iter().all(|&i| pos[i as usize][2] == z0));
        }
    }
}
