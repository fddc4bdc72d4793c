//! Packing the charts into one atlas: shelf packing (rows of rectangles,
//! tallest first) of each chart's texel rectangle grown by a gutter of
//! [`PADDING`] texels on every side, so that two charts' texels are at
//! least twice that apart and a chart's dilated border never reaches its
//! neighbour's.

/// The gutter around each chart's rectangle, in texels.
pub const PADDING: u32 = 2;

/// Where each rectangle went.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Packing {
    /// The atlas's size: the packed rectangles' bounds.
    pub width: u32,
    pub height: u32,
    /// Per rectangle, in input order, the texel its content starts at (its
    /// top-left corner, inside the gutter).
    pub origins: Vec<(u32, u32)>,
}

/// Packs rectangles of `sizes` (content texels, gutter not included) in
/// shelves of at most `width` texels (widened to the widest rectangle).
pub fn shelf_pack(sizes: &[(u32, u32)], width: u32) -> Packing {
    let padded: Vec<(u32, u32)> = sizes
        .iter()
        .map(|&(w, h)| (w + 2 * PADDING, h + 2 * PADDING))
        .collect();
    let width = padded.iter().map(|r| r.0).fold(width, u32::max);
    let mut order: Vec<usize> = (0..sizes.len()).collect();
    // Tallest first (then widest; then input order: deterministic).
    order.sort_by_key(|&i| {
        (
            std::cmp::Reverse(padded[i].1),
            std::cmp::Reverse(padded[i].0),
        )
    });
    let mut origins = vec![(0, 0); sizes.len()];
    let (mut x, mut y, mut shelf) = (0u32, 0u32, 0u32);
    let mut used_width = 0;
    for i in order {
        let (w, h) = padded[i];
        if x + w > width {
            y += shelf;
            x = 0;
            shelf = 0;
        }
        origins[i] = (x + PADDING, y + PADDING);
        x += w;
        shelf = shelf.max(h);
        used_width = used_width.max(x);
    }
    Packing {
        width: used_width.max(1),
        height: (y + shelf).max(1),
        origins,
    }
}

/// Packs `sizes` into an atlas about square, with neither side over
/// `max_side`; `None` when they cannot fit so.
pub fn pack(sizes: &[(u32, u32)], max_side: u32) -> Option<Packing> {
    let area: u64 = sizes
        .iter()
        .map(|&(w, h)| u64::from(w + 2 * PADDING) * u64::from(h + 2 * PADDING))
        .sum();
    // Shelves waste some room: start a little wider than the square.
    let side = ((area as f64).sqrt() * 1.05).ceil() as u32;
    let mut width = side.clamp(1, max_side);
    loop {
        let packing = shelf_pack(sizes, width);
        if packing.width <= max_side && packing.height <= max_side {
            return Some(packing);
        }
        if packing.width > max_side || width == max_side {
            return None;
        }
        // Too tall: wider shelves.
        width = (width + width / 4 + 1).min(max_side);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Content rectangles as [x0, y0, x1, y1), each with its gutter.
    fn rects(sizes: &[(u32, u32)], p: &Packing) -> Vec<[i64; 4]> {
        sizes
            .iter()
            .zip(&p.origins)
            .map(|(&(w, h), &(x, y))| {
                [
                    i64::from(x),
                    i64::from(y),
                    i64::from(x + w),
                    i64::from(y + h),
                ]
            })
            .collect()
    }

    fn sizes(seed: u64, n: usize) -> Vec<(u32, u32)> {
        // A small LCG: sizes from 1 to 60, some long and thin.
        let mut s = seed;
        let mut next = || {
            s = s
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            ((s >> 33) % 60 + 1) as u32
        };
        (0..n).map(|_| (next(), next())).collect()
    }

    #[test]
    fn packing_has_no_overlaps_and_respects_padding() {
        for seed in 0..8 {
            let sizes = sizes(seed, 40 + seed as usize * 10);
            let p = pack(&sizes, 4096).expect("fits");
            let pad = i64::from(PADDING);
            let r = rects(&sizes, &p);
            for (i, a) in r.iter().enumerate() {
                // The gutter lies inside the atlas.
                assert!(a[0] >= pad && a[1] >= pad, "{a:?}");
                assert!(a[2] + pad <= i64::from(p.width), "{a:?} in {}", p.width);
                assert!(a[3] + pad <= i64::from(p.height), "{a:?} in {}", p.height);
                for b in &r[i + 1..] {
                    // Contents at least two gutters apart on some axis.
                    let apart = a[2] + 2 * pad <= b[0]
                        || b[2] + 2 * pad <= a[0]
                        || a[3] + 2 * pad <= b[1]
                        || b[3] + 2 * pad <= a[1];
                    assert!(apart, "{a:?} and {b:?} closer than the gutters");
                }
            }
            // About square and not wasteful.
            let used: u64 = sizes.iter().map(|&(w, h)| u64::from(w * h)).sum();
            let total = u64::from(p.width) * u64::from(p.height);
            assert!(used * 3 > total, "{used} texels in {total}");
        }
    }

    #[test]
    fn too_much_does_not_fit() {
        assert!(pack(&[(100, 100); 4], 150).is_none());
        assert!(pack(&[(300, 10)], 200).is_none());
        let p = pack(&[(100, 100); 4], 300).unwrap();
        assert!(p.width <= 300 && p.height <= 300);
    }
}
