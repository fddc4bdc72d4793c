//! Self-intersecting faces: split into simple loops at the vertices they
//! visit twice and where their edges cross, and the check that those loops
//! lie side by side (a bow tie) rather than over each other (a pentagram).

use glam::{DVec2, DVec3};

use super::{on_segment, orient, reject, self_intersection, without_repeats, Plane, Rejection};

/// Most splits of one self-intersecting face; beyond that it is no shape
/// anyone meant.
const MAX_SPLITS: usize = 32;

/// Splits a polygon that crosses or touches itself into simple loops: at
/// a vertex it visits twice, and at the point where two edges cross (in
/// the projection onto `plane`). The loop that holds the first vertex comes
/// first. Each split makes both loops shorter, so this ends; a face that
/// needs more than `MAX_SPLITS` is refused. Also says whether it split.
pub(super) fn simple_loops(
    v: Vec<DVec3>,
    plane: &Plane,
    eps: f64,
) -> Result<(Vec<Vec<DVec3>>, bool), Rejection> {
    let mut done = Vec::new();
    let mut todo = vec![v];
    let mut splits = 0;
    while let Some(lp) = todo.pop() {
        let lp = without_repeats(&lp, eps);
        if lp.len() < 3 {
            continue;
        }
        let Some((a, b)) = split_loop(&lp, &plane.flat(&lp), eps) else {
            done.push(lp);
            continue;
        };
        splits += 1;
        if splits > MAX_SPLITS {
            return Err(reject(
                format!("the face crosses or touches itself more than {MAX_SPLITS} times"),
                "list the vertices in order around the boundary, or split the face",
            ));
        }
        // `b` holds the first vertex: it is taken next, and stays first.
        todo.push(a);
        todo.push(b);
    }
    Ok((done, splits > 0))
}

/// Whether two of the simple loops overlap: an edge of one properly
/// crosses an edge of another, or a point of one lies inside another (not
/// on its boundary). Loops that only touch do not.
pub(super) fn loops_overlap(loops: &[Vec<DVec3>], plane: &Plane, eps: f64) -> bool {
    let flat: Vec<Vec<DVec2>> = loops.iter().map(|lp| plane.flat(lp)).collect();
    let edges = |p: &[DVec2]| -> Vec<(DVec2, DVec2)> {
        (0..p.len()).map(|i| (p[i], p[(i + 1) % p.len()])).collect()
    };
    let near_boundary = |q: DVec2, p: &[DVec2]| {
        edges(p).iter().any(|&(a, b)| {
            let ab = b - a;
            let t = ((q - a).dot(ab) / ab.length_squared().max(f64::MIN_POSITIVE)).clamp(0.0, 1.0);
            (a + t * ab).distance(q) <= eps
        })
    };
    let inside = |q: DVec2, p: &[DVec2]| {
        // Crossing number of a ray towards +x.
        let mut odd = false;
        for (a, b) in edges(p) {
            if (a.y > q.y) != (b.y > q.y) && q.x < a.x + (q.y - a.y) / (b.y - a.y) * (b.x - a.x) {
                odd = !odd;
            }
        }
        odd
    };
    let centroid = |p: &[DVec2]| p.iter().copied().sum::<DVec2>() / p.len() as f64;
    for (i, a) in flat.iter().enumerate() {
        for b in &flat[i + 1..] {
            for &(p, q) in &edges(a) {
                for &(r, s) in &edges(b) {
                    let (o1, o2) = (orient(p, q, r), orient(p, q, s));
                    let (o3, o4) = (orient(r, s, p), orient(r, s, q));
                    if o1 * o2 < 0.0 && o3 * o4 < 0.0 {
                        return true;
                    }
                }
            }
            for (x, y) in [(a, b), (b, a)] {
                let off: Vec<DVec2> = x
                    .iter()
                    .copied()
                    .filter(|&q| !near_boundary(q, y))
                    .collect();
                let probe = if off.is_empty() {
                    vec![centroid(x)]
                } else {
                    off
                };
                if probe.iter().any(|&q| inside(q, y) && !near_boundary(q, y)) {
                    return true;
                }
            }
        }
    }
    false
}

/// One split of a loop that is not simple: (the part after the first
/// vertex, the part holding the first vertex), or `None` when it is simple.
fn split_loop(v: &[DVec3], flat: &[DVec2], eps: f64) -> Option<(Vec<DVec3>, Vec<DVec3>)> {
    let m = v.len();
    // A vertex visited twice: a b c b d -> (b c), (b d a).
    for i in 0..m {
        for j in i + 1..m {
            if v[i].distance(v[j]) <= eps {
                let inner = v[i..j].to_vec();
                let outer = v[j..].iter().chain(&v[..i]).copied().collect();
                return Some((inner, outer));
            }
        }
    }
    let (i, j) = self_intersection(flat)?;
    let x = crossing(v, flat, i, j);
    // Edge i runs a -> x -> a', edge j runs c -> x -> c'.
    let inner = std::iter::once(x)
        .chain(v[i + 1..=j].iter().copied())
        .collect();
    let outer = std::iter::once(x)
        .chain(v[j + 1..].iter().copied())
        .chain(v[..=i].iter().copied())
        .collect();
    Some((inner, outer))
}

/// Where edges `i` and `j` of the loop meet, as a point on edge `i` (the
/// face may be a little non-planar).
fn crossing(v: &[DVec3], p: &[DVec2], i: usize, j: usize) -> DVec3 {
    let m = v.len();
    let (a, b, c, d) = (p[i], p[(i + 1) % m], p[j], p[(j + 1) % m]);
    let (o3, o4) = (orient(c, d, a), orient(c, d, b));
    if o3 != o4 {
        let t = (o3 / (o3 - o4)).clamp(0.0, 1.0);
        return v[i].lerp(v[(i + 1) % m], t);
    }
    // Collinear overlap: an end of one edge lies on the other.
    if on_segment(c, a, b) {
        v[j]
    } else if on_segment(d, a, b) {
        v[(j + 1) % m]
    } else if on_segment(a, c, d) {
        v[i]
    } else {
        v[(i + 1) % m]
    }
}
