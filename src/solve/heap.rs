//! An indexed binary max-heap of unshot power, to pick the next shooter.
//!
//! Items are `0..n` (element indices) and stay in the heap for good: a shot
//! element gets key 0 via [`IndexedMaxHeap::set_key`], it is not removed.
//! Building is O(n), `peek` O(1), `set_key` O(log n). Ties are broken by the
//! smaller item index, so the order is deterministic.

/// A binary max-heap over items `0..n` keyed by finite `f32`s, with each
/// item's heap position tracked so its key can be changed in place.
#[derive(Debug, Clone, Default)]
pub struct IndexedMaxHeap {
    /// `keys[item]`.
    keys: Vec<f32>,
    /// `heap[position] = item`.
    heap: Vec<u32>,
    /// `pos[item] = position` in `heap`.
    pos: Vec<u32>,
}

impl IndexedMaxHeap {
    /// Builds the heap over items `0..keys.len()` with `keys[i]` for item
    /// `i`, by bottom-up heapify in O(n).
    pub fn from_keys(keys: Vec<f32>) -> Self {
        debug_assert!(
            keys.iter().all(|k| k.is_finite()),
            "heap keys must be finite"
        );
        let n = keys.len();
        debug_assert!(u32::try_from(n).is_ok(), "too many heap items");
        let mut h = IndexedMaxHeap {
            keys,
            heap: (0..n as u32).collect(),
            pos: (0..n as u32).collect(),
        };
        for p in (0..n / 2).rev() {
            h.sift_down(p);
        }
        h
    }

    /// The number of items.
    #[cfg(any(test, feature = "internals"))]
    pub fn len(&self) -> usize {
        self.keys.len()
    }

    #[cfg(any(test, feature = "internals"))]
    pub fn is_empty(&self) -> bool {
        self.keys.is_empty()
    }

    /// The item with the largest key (the smallest index among equal keys)
    /// and its key; `None` when there are no items.
    pub fn peek(&self) -> Option<(usize, f32)> {
        self.heap
            .first()
            .map(|&i| (i as usize, self.keys[i as usize]))
    }

    /// The current key of `item`. Panics when `item >= len()`.
    #[cfg(any(test, feature = "internals"))]
    pub fn key(&self, item: usize) -> f32 {
        self.keys[item]
    }

    /// All keys, indexed by item.
    #[cfg(any(test, feature = "internals"))]
    pub fn keys(&self) -> &[f32] {
        &self.keys
    }

    /// Changes `item`'s key and restores the heap order in O(log n).
    /// Panics when `item >= len()`.
    pub fn set_key(&mut self, item: usize, key: f32) {
        debug_assert!(key.is_finite(), "heap keys must be finite, got {key}");
        let old = self.keys[item];
        self.keys[item] = key;
        let p = self.pos[item] as usize;
        if key > old {
            self.sift_up(p);
        } else if key < old {
            self.sift_down(p);
        }
    }

    /// Whether item `a` belongs above item `b`: larger key, then smaller index.
    #[inline]
    fn above(&self, a: u32, b: u32) -> bool {
        let (ka, kb) = (self.keys[a as usize], self.keys[b as usize]);
        ka > kb || (ka == kb && a < b)
    }

    #[inline]
    fn place(&mut self, p: usize, item: u32) {
        self.heap[p] = item;
        self.pos[item as usize] = p as u32;
    }

    fn sift_up(&mut self, mut p: usize) {
        let item = self.heap[p];
        while p > 0 {
            let parent = (p - 1) / 2;
            let pi = self.heap[parent];
            if !self.above(item, pi) {
                break;
            }
            self.place(p, pi);
            p = parent;
        }
        self.place(p, item);
    }

    fn sift_down(&mut self, mut p: usize) {
        let n = self.heap.len();
        let item = self.heap[p];
        loop {
            let l = 2 * p + 1;
            if l >= n {
                break;
            }
            let r = l + 1;
            let mut c = l;
            if r < n && self.above(self.heap[r], self.heap[l]) {
                c = r;
            }
            let ci = self.heap[c];
            if !self.above(ci, item) {
                break;
            }
            self.place(p, ci);
            p = c;
        }
        self.place(p, item);
    }

    /// Checks the heap invariants (for tests and debugging).
    #[cfg(test)]
    fn check(&self) {
        let n = self.heap.len();
        assert_eq!(self.pos.len(), n);
        for p in 0..n {
            assert_eq!(self.pos[self.heap[p] as usize] as usize, p);
            if p > 0 {
                assert!(self.above(self.heap[(p - 1) / 2], self.heap[p]));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A tiny deterministic LCG (Numerical Recipes constants).
    struct Lcg(u64);
    impl Lcg {
        fn next_u32(&mut self) -> u32 {
            self.0 = self
                .0
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (self.0 >> 33) as u32
        }
        fn below(&mut self, n: usize) -> usize {
            self.next_u32() as usize % n
        }
        fn key(&mut self) -> f32 {
            // Few distinct values so ties are common; some zeros.
            (self.next_u32() % 16) as f32 * 0.25
        }
    }

    /// Largest key, smallest index among ties.
    fn brute_max(keys: &[f32]) -> Option<(usize, f32)> {
        let mut best: Option<(usize, f32)> = None;
        for (i, &k) in keys.iter().enumerate() {
            if best.is_none_or(|(_, bk)| k > bk) {
                best = Some((i, k));
            }
        }
        best
    }

    #[test]
    fn empty_and_single() {
        let h = IndexedMaxHeap::from_keys(vec![]);
        assert!(h.is_empty());
        assert_eq!(h.len(), 0);
        assert_eq!(h.peek(), None);

        let mut h = IndexedMaxHeap::from_keys(vec![2.5]);
        assert_eq!(h.len(), 1);
        assert_eq!(h.peek(), Some((0, 2.5)));
        h.set_key(0, 0.0);
        assert_eq!(h.peek(), Some((0, 0.0)));
        assert_eq!(h.key(0), 0.0);
        h.check();
    }

    #[test]
    fn ties_prefer_smaller_index() {
        let mut h = IndexedMaxHeap::from_keys(vec![1.0, 3.0, 3.0, 2.0, 3.0]);
        h.check();
        assert_eq!(h.peek(), Some((1, 3.0)));
        h.set_key(1, 0.0);
        assert_eq!(h.peek(), Some((2, 3.0)));
        h.set_key(2, 0.0);
        assert_eq!(h.peek(), Some((4, 3.0)));
        h.set_key(4, 0.0);
        assert_eq!(h.peek(), Some((3, 2.0)));
        h.set_key(0, 2.0);
        assert_eq!(h.peek(), Some((0, 2.0)));
        let all_equal = IndexedMaxHeap::from_keys(vec![0.0; 9]);
        assert_eq!(all_equal.peek(), Some((0, 0.0)));
        all_equal.check();
    }

    #[test]
    fn shooting_order_drains_to_zero() {
        // Shoot the max and zero it, n times: keys come out non-increasing.
        let keys = vec![5.0, 1.0, 4.0, 1.0, 5.0, 9.0, 2.0, 6.0];
        let mut h = IndexedMaxHeap::from_keys(keys);
        let mut out = Vec::new();
        for _ in 0..h.len() {
            let (i, k) = h.peek().unwrap();
            out.push((i, k));
            h.set_key(i, 0.0);
            h.check();
        }
        assert_eq!(
            out,
            vec![
                (5, 9.0),
                (7, 6.0),
                (0, 5.0),
                (4, 5.0),
                (2, 4.0),
                (6, 2.0),
                (1, 1.0),
                (3, 1.0)
            ]
        );
        assert!(h.keys().iter().all(|&k| k == 0.0));
    }

    #[test]
    fn random_updates_match_brute_force() {
        let mut rng = Lcg(0x5eed);
        for n in [2usize, 3, 7, 64, 257] {
            let keys: Vec<f32> = (0..n).map(|_| rng.key()).collect();
            let mut shadow = keys.clone();
            let mut h = IndexedMaxHeap::from_keys(keys);
            h.check();
            assert_eq!(h.peek(), brute_max(&shadow));
            for step in 0..4 * n + 50 {
                let item = rng.below(n);
                let key = if step % 5 == 0 { 0.0 } else { rng.key() };
                h.set_key(item, key);
                shadow[item] = key;
                assert_eq!(h.peek(), brute_max(&shadow), "n {n} step {step}");
                assert_eq!(h.key(item), key);
                if step % 17 == 0 {
                    h.check();
                }
            }
            h.check();
            assert_eq!(h.keys(), &shadow[..]);
        }
    }

    #[test]
    fn continuous_keys() {
        let mut rng = Lcg(42);
        let n = 1000;
        let keys: Vec<f32> = (0..n).map(|_| rng.next_u32() as f32 / 7.0).collect();
        let mut shadow = keys.clone();
        let mut h = IndexedMaxHeap::from_keys(keys);
        for _ in 0..5000 {
            let item = rng.below(n);
            let key = rng.next_u32() as f32 / 11.0;
            h.set_key(item, key);
            shadow[item] = key;
            assert_eq!(h.peek(), brute_max(&shadow));
        }
        h.check();
    }
}
