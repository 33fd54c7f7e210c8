//! Bottom-up BVH over a chain of segments (the method's broad phase).
//!
//! Leaves are the segments in chain order; each level merges neighbours pairwise (an odd one
//! out is carried up), so building is O(n) with no sorting and the tree follows the midline.
//! The topology depends only on the leaf count: a new frame only refits the boxes.
//!
//! Node layout: level 0 holds the leaves, level `k + 1` holds `ceil(len_k / 2)` parents; node
//! `j` of level `k + 1` has children `2j` and `2j + 1` of level `k` (the second may not exist).

use crate::broad::aabb::Aabb;
use crate::V3;

/// A chain BVH. Boxes are stored level after level, leaves first.
#[derive(Debug, Clone, Default)]
pub struct ChainBvh {
    boxes: Vec<Aabb>,
    /// Start of each level in `boxes`; the last level is the root alone.
    levels: Vec<usize>,
}

impl ChainBvh {
    /// Number of leaves.
    pub fn leaves(&self) -> usize {
        self.levels.get(1).copied().unwrap_or(self.boxes.len())
    }

    /// Box of leaf `i`.
    pub fn leaf(&self, i: usize) -> &Aabb {
        &self.boxes[i]
    }

    /// Rebuilds the tree from leaf boxes written by `leaf(i)` for `i < n` (allocation only when
    /// `n` grows).
    pub fn build(&mut self, n: usize, mut leaf: impl FnMut(usize) -> Aabb) {
        if n != self.leaves() || self.levels.is_empty() {
            self.levels.clear();
            self.boxes.clear();
            let mut len = n;
            let mut start = 0;
            loop {
                self.levels.push(start);
                start += len;
                if len <= 1 {
                    break;
                }
                len = len.div_ceil(2);
            }
            self.boxes.resize(start, Aabb::EMPTY);
        }
        for (i, b) in self.boxes[..n].iter_mut().enumerate() {
            *b = leaf(i);
        }
        for k in 1..self.levels.len() {
            let (below, this) = (self.levels[k - 1], self.levels[k]);
            let len_below = this - below;
            let len = self.level_len(k);
            for j in 0..len {
                let a = self.boxes[below + 2 * j];
                let m = if 2 * j + 1 < len_below { a.merge(&self.boxes[below + 2 * j + 1]) } else { a };
                self.boxes[this + j] = m;
            }
        }
    }

    fn level_len(&self, k: usize) -> usize {
        let next = self.levels.get(k + 1).copied().unwrap_or(self.boxes.len());
        next - self.levels[k]
    }

    fn root(&self) -> Option<(usize, usize)> {
        (!self.boxes.is_empty()).then(|| (self.levels.len() - 1, 0))
    }

    fn node(&self, level: usize, j: usize) -> &Aabb {
        &self.boxes[self.levels[level] + j]
    }

    fn children(&self, level: usize, j: usize) -> impl Iterator<Item = usize> {
        let below = self.level_len(level - 1);
        2 * j..(2 * j + 2).min(below)
    }

    /// Calls `hit(i)` for every leaf whose box overlaps `q`.
    pub fn query(&self, q: &Aabb, mut hit: impl FnMut(usize)) {
        let Some(root) = self.root() else { return };
        let mut stack = [(0usize, 0usize); 64];
        let mut top = 0;
        stack[0] = root;
        top += 1;
        while top > 0 {
            top -= 1;
            let (level, j) = stack[top];
            if !self.node(level, j).overlaps(q) {
                continue;
            }
            if level == 0 {
                hit(j);
            } else {
                for c in self.children(level, j) {
                    stack[top] = (level - 1, c);
                    top += 1;
                }
            }
        }
    }

    /// Depth-first dual traversal: calls `hit(i, j)` for every leaf `i` of `self` and leaf `j`
    /// of `other` whose boxes overlap, in a deterministic order.
    pub fn pairs(&self, other: &ChainBvh, mut hit: impl FnMut(usize, usize)) {
        let (Some(a), Some(b)) = (self.root(), other.root()) else { return };
        // 2 * 32 levels deep at most: leaf counts are bounded far below 2^32.
        let mut stack = [((0usize, 0usize), (0usize, 0usize)); 256];
        stack[0] = (a, b);
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let ((la, ja), (lb, jb)) = stack[top];
            if !self.node(la, ja).overlaps(other.node(lb, jb)) {
                continue;
            }
            match (la, lb) {
                (0, 0) => hit(ja, jb),
                // Descend the larger level (deeper tree) first; push in reverse for order.
                _ if la >= lb && la > 0 => {
                    let kids: [usize; 2] = [2 * ja, 2 * ja + 1];
                    let n = self.children(la, ja).count();
                    for &c in kids[..n].iter().rev() {
                        stack[top] = ((la - 1, c), (lb, jb));
                        top += 1;
                    }
                }
                _ => {
                    let kids: [usize; 2] = [2 * jb, 2 * jb + 1];
                    let n = other.children(lb, jb).count();
                    for &c in kids[..n].iter().rev() {
                        stack[top] = ((la, ja), (lb - 1, c));
                        top += 1;
                    }
                }
            }
        }
    }

    /// The leaf minimising `cost(i)`, searched best-first with box distance to `p` as the lower
    /// bound (`cost(i)` must be >= the squared distance from `p` to leaf box `i`). Returns the
    /// leaf and its cost.
    pub fn nearest(&self, p: V3, mut cost: impl FnMut(usize) -> f32) -> Option<(usize, f32)> {
        let root = self.root()?;
        let mut best: Option<(usize, f32)> = None;
        let mut stack = [((0usize, 0usize), 0f32); 64];
        stack[0] = (root, self.node(root.0, root.1).distance2(p));
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let ((level, j), d2) = stack[top];
            if best.is_some_and(|(_, c)| d2 >= c) {
                continue;
            }
            if level == 0 {
                let c = cost(j);
                if best.is_none_or(|(_, b)| c < b) {
                    best = Some((j, c));
                }
                continue;
            }
            // Push the farther child first so the nearer is searched first.
            let mut kids = [((level - 1, 0usize), f32::INFINITY); 2];
            let mut n = 0;
            for c in self.children(level, j) {
                kids[n] = ((level - 1, c), self.node(level - 1, c).distance2(p));
                n += 1;
            }
            if n == 2 && kids[0].1 < kids[1].1 {
                kids.swap(0, 1);
            }
            for k in &kids[..n] {
                stack[top] = *k;
                top += 1;
            }
        }
        best
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit(i: usize) -> Aabb {
        let p = V3::new(i as f32, 0.0, 0.0);
        Aabb { min: p, max: p + V3::new(1.0, 1.0, 1.0) }
    }

    #[test]
    fn pairs_match_brute_force_for_every_size() {
        for n in 1..40 {
            let mut a = ChainBvh::default();
            a.build(n, unit);
            let mut b = ChainBvh::default();
            b.build(7, |i| unit(i * 3).inflate(0.1));
            let mut got = vec![];
            a.pairs(&b, |i, j| got.push((i, j)));
            let mut want = vec![];
            for i in 0..n {
                for j in 0..7 {
                    if a.leaf(i).overlaps(b.leaf(j)) {
                        want.push((i, j));
                    }
                }
            }
            got.sort();
            assert_eq!(got, want, "n = {n}");
            let mut q = vec![];
            a.query(&unit(5).inflate(0.5), |i| q.push(i));
            q.sort();
            assert_eq!(q, (4..n.min(7)).collect::<Vec<_>>(), "n = {n}");
        }
    }

    #[test]
    fn nearest_finds_the_minimum() {
        let mut a = ChainBvh::default();
        a.build(33, unit);
        let p = V3::new(20.5, 5.0, 0.5);
        let (i, d) = a.nearest(p, |i| a.leaf(i).distance2(p) + (i as f32 - 20.0).abs()).unwrap();
        assert_eq!(i, 20);
        assert!((d - 16.0).abs() < 1e-4);
    }
}
