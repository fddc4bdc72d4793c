//! The GPU ray passes (`gpu::rays`) against the CPU on the same work, side
//! by side in one run: segments per second of `OcclusionPass::visible`
//! against `Occluders::visible` over rayon (the same segments: between
//! random points on random patches, both patches skipped), first hits of
//! `FirstHitPass::first_hits` against `Occluders::first_hit_beyond` (rays
//! from those points over their patch's front, as the gather's
//! hemisphere rays), and the
//! emitters' light at N gather points (`SourceGatherPass::gather`) against
//! a CPU loop doing the same work (exact F, 16 first rays and the corners,
//! then the full count in penumbrae). Medians of `--repeats` runs, wall
//! time including uploads and readbacks.
//!
//!     cargo bench --bench gpu_rays -- [--segments N] [--points N] [--rays N] [--repeats N] [--device SEL] [SCENE...]
//!
//! SCENE: built-in names or .obj paths (default: cornell, rfield).

use std::sync::Arc;
use std::time::Instant;

mod common;

use common::{arg, device_selector, median};
use glam::{DVec3, Vec3};
use rayon::prelude::*;
use vkrad::formfactor::analytic::point_to_polygon;
use vkrad::formfactor::raytrace::flat_bvh::FlatBvh;
use vkrad::formfactor::raytrace::Occluders;
use vkrad::formfactor::sampling::Pcg32;
use vkrad::gpu::rays::{
    FirstHitPass, GatherPoint, GatherSource, GpuBvh, OcclusionPass, Ray, Segment, SourceGatherPass,
};
use vkrad::gpu::{Device, DeviceOptions};
use vkrad::scene::Scene;

/// A random patch (area-weighted) and a uniform point on it.
fn point_on(scene: &Scene, cdf: &[f32], rng: &mut Pcg32) -> (usize, Vec3) {
    let u = rng.next_f32() * cdf[cdf.len() - 1];
    let p = cdf.partition_point(|&c| c < u).min(cdf.len() - 1);
    let v = &scene.patches[p].vertices;
    let k = 1 + ((rng.next_f32() * (v.len() - 2) as f32) as usize).min(v.len() - 3);
    let (mut a, mut b) = (rng.next_f32(), rng.next_f32());
    if a + b > 1.0 {
        (a, b) = (1.0 - a, 1.0 - b);
    }
    (p, v[0] + a * (v[k] - v[0]) + b * (v[k + 1] - v[0]))
}

/// Time `f` `repeats` times; the median seconds and the last result.
fn timed<T>(repeats: usize, mut f: impl FnMut() -> T) -> (f64, T) {
    let mut times = vec![];
    let mut last = None;
    for _ in 0..repeats {
        let t = Instant::now();
        last = Some(f());
        times.push(t.elapsed().as_secs_f64());
    }
    (median(times), last.expect("at least one repeat"))
}

/// The CPU twin of `glsl/gather_sources.comp` for one point and source.
fn cpu_source(occ: &Occluders, g: &GatherPoint, s: &GatherSource, rng: &mut Pcg32) -> f32 {
    let k = s.corner_count as usize;
    let poly: Vec<DVec3> = s.corners[..k]
        .iter()
        .map(|c| Vec3::new(c[0], c[1], c[2]).as_dvec3())
        .collect();
    let (p, n) = (Vec3::from(g.p), Vec3::from(g.n));
    let exact = point_to_polygon(p.as_dvec3(), n.as_dvec3(), &poly) as f32;
    if exact.is_nan() || exact <= 0.0 {
        return 0.0;
    }
    let corners: Vec<Vec3> = poly.iter().map(|c| c.as_vec3()).collect();
    let ns = Vec3::from(s.normal);
    let skip = [g.patch, s.patch];
    let weight = |rays: usize, rng: &mut Pcg32| {
        let rows = ((rays as f64).sqrt() as usize..=rays)
            .find(|r| rays % r == 0)
            .unwrap_or(1);
        let cols = rays / rows;
        let (mut seen, mut all) = (0.0f32, 0.0f32);
        for r in 0..rows {
            for c in 0..cols {
                let u = (r as f32 + rng.next_f32()) / rows as f32;
                let w = (c as f32 + rng.next_f32()) / cols as f32;
                // The fan's first triangles by area share (enough for the
                // work count: a quad's two halves).
                let t = 1 + ((u * (k - 2) as f32) as usize).min(k - 3);
                let s2 = (u * (k - 2) as f32 - (t - 1) as f32).sqrt();
                let x = corners[0]
                    + s2 * ((corners[t] - corners[0]) + w * (corners[t + 1] - corners[t]));
                let d = x - p;
                let r2 = d.length_squared();
                let (cv, cs) = (n.dot(d), -ns.dot(d));
                if r2 <= 0.0 || cv <= 0.0 || cs <= 0.0 {
                    continue;
                }
                let term = cv * cs / (r2 * r2);
                all += term;
                if occ.visible(p, x, skip) {
                    seen += term;
                }
            }
        }
        (seen, all)
    };
    let rays = s.rays as usize;
    if s.early_out != 0 && rays > 32 {
        let (seen, all) = weight(16, rng);
        if all <= 0.0 {
            return 0.0;
        }
        let centre = corners.iter().sum::<Vec3>() / k as f32;
        let (mut cs, mut front) = (0, 0);
        for &c in &corners {
            let x = c + 1e-3 * (centre - c);
            let d = x - p;
            if n.dot(d) <= 0.0 || ns.dot(d) >= 0.0 {
                continue;
            }
            front += 1;
            cs += usize::from(occ.visible(p, x, skip));
        }
        if (seen <= 0.0 && cs == 0) || (seen >= all && cs == front) {
            return exact * seen / all;
        }
    }
    let (seen, all) = weight(rays, rng);
    if all <= 0.0 {
        0.0
    } else {
        exact * seen / all
    }
}

fn main() {
    let n_segments: usize = arg("--segments", 400_000);
    let n_points: usize = arg("--points", 4096);
    let rays: u32 = arg("--rays", 256);
    let repeats: usize = arg("--repeats", 5);
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut scenes: Vec<String> = Vec::new();
    let mut k = 0;
    while k < args.len() {
        match args[k].as_str() {
            "--segments" | "--points" | "--rays" | "--repeats" | "--device" => k += 1,
            a if a.starts_with("--") => {}
            a => scenes.push(a.to_string()),
        }
        k += 1;
    }
    if scenes.is_empty() {
        scenes = vec!["cornell".into(), "rfield".into()];
    }
    let device = Device::new(&DeviceOptions {
        selector: device_selector(),
        validate: false,
        ..Default::default()
    })
    .expect("a Vulkan device");
    let threads = rayon::current_num_threads();
    println!(
        "gpu_rays: {} ({}), {threads} CPU threads, medians of {repeats}",
        device.info.name, device.info.kind
    );
    for name in &scenes {
        let scene = vkrad::scene::load_scene_arg(name).expect("scene loads");
        let t = Instant::now();
        let occ = Occluders::new(&scene);
        let obvhs_s = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let flat = FlatBvh::new(&scene);
        let flat_s = t.elapsed().as_secs_f64();
        let bvh = Arc::new(
            GpuBvh::new(&device, &flat.nodes, &flat.triangles, flat.eps).expect("bvh upload"),
        );
        println!(
            "  {name}: {} patches, {} triangles; build obvhs {:.1} ms, flat BVH {:.1} ms ({} nodes)",
            scene.patches.len(),
            flat.triangles.len(),
            1e3 * obvhs_s,
            1e3 * flat_s,
            flat.nodes.len()
        );
        let mut cdf = Vec::with_capacity(scene.patches.len());
        let mut total = 0.0;
        for p in &scene.patches {
            total += p.area;
            cdf.push(total);
        }
        let mut rng = Pcg32::new(0x5eed, 0);
        let segments: Vec<Segment> = (0..n_segments)
            .map(|_| {
                let (pa, a) = point_on(&scene, &cdf, &mut rng);
                let (pb, b) = point_on(&scene, &cdf, &mut rng);
                Segment::new(a.into(), b.into(), [pa as u32, pb as u32])
            })
            .collect();
        let (cpu_s, cpu) = timed(repeats, || {
            segments
                .par_iter()
                .map(|s| occ.visible(s.a.into(), s.b.into(), [s.skip0, s.skip1]))
                .collect::<Vec<bool>>()
        });
        let mut pass = OcclusionPass::new(&device, bvh.clone()).expect("occlusion pass");
        let (gpu_s, gpu) = timed(repeats, || pass.visible(&segments).expect("gpu segments"));
        // The flat BVH walked on the CPU (the GPU's tree, the CPU's
        // arithmetic): which of the two a disagreement comes from.
        let (flat_s, walk) = timed(repeats, || {
            segments
                .par_iter()
                .map(|s| flat.visible(s.a.into(), s.b.into(), [s.skip0, s.skip1]))
                .collect::<Vec<bool>>()
        });
        let count = |x: &[bool], y: &[bool]| x.iter().zip(y).filter(|(a, b)| a != b).count();
        let (tree_differ, gpu_differ) = (count(&cpu, &walk), count(&walk, &gpu));
        let differ = count(&cpu, &gpu);
        // Where the trees disagree, every triangle tested decides.
        let brute_sides_with_flat = (0..n_segments)
            .filter(|&i| cpu[i] != walk[i])
            .filter(|&i| {
                let s = &segments[i];
                flat.visible_brute_force(s.a.into(), s.b.into(), [s.skip0, s.skip1]) == walk[i]
            })
            .count();
        let blocked = cpu.iter().filter(|v| !**v).count();
        println!(
            "    segments: {n_segments} ({:.1}% blocked): CPU obvhs {:.2} Mrays/s, CPU flat BVH {:.2} Mrays/s ({threads} threads), GPU {:.2} Mrays/s; GPU vs obvhs: {differ} disagree (flat BVH on the CPU vs obvhs {tree_differ}, GPU vs flat BVH on the CPU {gpu_differ}; testing every triangle agrees with the flat BVH in {brute_sides_with_flat} of the {tree_differ})",
            100.0 * blocked as f64 / n_segments as f64,
            n_segments as f64 / cpu_s / 1e6,
            n_segments as f64 / flat_s / 1e6,
            n_segments as f64 / gpu_s / 1e6,
        );
        // First hits: from the segments' first ends over their patch's
        // front, towards the second ends (flipped to the front).
        let hemisphere: Vec<Ray> = segments
            .iter()
            .map(|s| {
                let normal = scene.patches[s.skip0 as usize].normal;
                let mut d = (Vec3::from(s.b) - Vec3::from(s.a)).normalize_or(normal);
                if d.dot(normal) < 0.0 {
                    d = -d;
                }
                Ray {
                    a: (Vec3::from(s.a) + occ.epsilon() * normal).into(),
                    skip: s.skip0,
                    d: d.into(),
                    tmin: 0.0,
                }
            })
            .collect();
        let (cpu_s, cpu_hits) = timed(repeats, || {
            hemisphere
                .par_iter()
                .map(|r| occ.first_hit_beyond(r.a.into(), r.d.into(), r.tmin, r.skip))
                .collect::<Vec<_>>()
        });
        let mut first = FirstHitPass::new(&device, bvh.clone()).expect("first-hit pass");
        let (gpu_s, gpu_hits) = timed(repeats, || {
            first.first_hits(&hemisphere).expect("gpu first hits")
        });
        let differ = cpu_hits
            .iter()
            .zip(&gpu_hits)
            .filter(|(c, g)| match (c, g.met()) {
                (None, None) => false,
                (Some((tc, _)), Some((tg, _))) => (tc - tg).abs() > 1e-4 * tc.max(1.0),
                _ => true,
            })
            .count();
        println!(
            "    first hits: {n_segments}: CPU obvhs {:.2} Mrays/s ({threads} threads), GPU {:.2} Mrays/s; {differ} disagree",
            n_segments as f64 / cpu_s / 1e6,
            n_segments as f64 / gpu_s / 1e6,
        );
        // The emitters' light at points on random patches.
        let sources: Vec<GatherSource> = scene
            .patches
            .iter()
            .enumerate()
            .filter(|(_, p)| {
                scene.material_of(p).is_emitter() && (3..=8).contains(&p.vertices.len())
            })
            .map(|(i, p)| {
                let c: Vec<[f32; 3]> = p.vertices.iter().map(|v| v.to_array()).collect();
                let e = scene.material_of(p).emission * std::f32::consts::PI;
                GatherSource::new(&c, p.normal.to_array(), i as u32, e.to_array(), rays, true)
            })
            .collect();
        let points: Vec<GatherPoint> = (0..n_points)
            .map(|i| {
                let (p, x) = point_on(&scene, &cdf, &mut rng);
                GatherPoint {
                    p: x.to_array(),
                    patch: p as u32,
                    n: scene.patches[p].normal.to_array(),
                    stream: i as u32,
                }
            })
            .collect();
        let (cpu_s, cpu) = timed(repeats, || {
            points
                .par_iter()
                .map(|g| {
                    let mut rng = Pcg32::new(u64::from(g.stream), 0);
                    sources
                        .iter()
                        .map(|s| cpu_source(&occ, g, s, &mut rng) * s.radiosity[0])
                        .sum::<f32>()
                })
                .collect::<Vec<f32>>()
        });
        let mut gather = SourceGatherPass::new(&device, bvh).expect("gather pass");
        let (gpu_s, gpu) = timed(repeats, || {
            gather.gather(&points, &sources, 1).expect("gpu gather")
        });
        let (sc, sg): (f64, f64) = cpu.iter().zip(&gpu).fold((0.0, 0.0), |(a, b), (c, g)| {
            (a + *c as f64, b + g[0] as f64)
        });
        println!(
            "    source gather: {n_points} points x {} emitters x {rays} rays: CPU {:.3} ms/point ({threads} threads, wall), GPU {:.3} ms/point; sums CPU {sc:.4e}, GPU {sg:.4e} ({:+.2}%)",
            sources.len(),
            1e3 * cpu_s / n_points as f64,
            1e3 * gpu_s / n_points as f64,
            100.0 * (sg - sc) / sc.abs().max(1e-30),
        );
    }
}
