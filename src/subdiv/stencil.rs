//! Stencils: each refined value a weighted sum of values before, stored flat.

/// A list of stencils, each `[(index, weight), ...]`, stored flat.
#[derive(Clone, Debug, Default)]
pub struct Stencils {
    start: Vec<u32>,
    idx: Vec<u32>,
    w: Vec<f64>,
}

impl Stencils {
    pub fn with_capacity(n: usize) -> Stencils {
        let mut start = Vec::with_capacity(n + 1);
        start.push(0);
        Stencils { start, idx: Vec::with_capacity(4 * n), w: Vec::with_capacity(4 * n) }
    }

    pub fn push(&mut self, terms: &[(u32, f64)]) {
        for &(i, w) in terms {
            self.idx.push(i);
            self.w.push(w);
        }
        self.start.push(self.idx.len() as u32);
    }

    pub fn len(&self) -> usize {
        self.start.len().saturating_sub(1)
    }

    /// Stencil `i` as `(indices, weights)`.
    pub fn get(&self, i: usize) -> (&[u32], &[f64]) {
        let r = self.start[i] as usize..self.start[i + 1] as usize;
        (&self.idx[r.clone()], &self.w[r])
    }

    /// Each stencil applied to `data` (`width` values per element).
    pub fn apply(&self, data: &[f64], width: usize) -> Vec<f64> {
        let mut out = vec![0.0; self.len() * width];
        for (n, o) in out.chunks_exact_mut(width).enumerate() {
            let (idx, w) = self.get(n);
            for (&i, &w) in idx.iter().zip(w) {
                let src = &data[i as usize * width..(i as usize + 1) * width];
                for (o, s) in o.iter_mut().zip(src) {
                    *o += w * s;
                }
            }
        }
        out
    }
}

/// `(1 − s) p + s q` of two stencils.
pub fn blend(p: &[(u32, f64)], q: &[(u32, f64)], s: f64) -> Vec<(u32, f64)> {
    p.iter().map(|&(i, w)| (i, w * (1.0 - s))).chain(q.iter().map(|&(i, w)| (i, w * s))).collect()
}
