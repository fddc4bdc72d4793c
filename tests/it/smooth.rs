//! A finely tessellated sphere under an area light, at the default
//! settings: every input triangle is its own patch, gathered once per
//! smooth group of vertices, yet each facet's corners show the exact
//! irradiance on the facet's own plane (as a path tracer shades flat
//! triangles, and as the pixel gather does), with no speckle.

use glam::{DVec3, Vec3};
use vkrad::app::{run_scene, Job};
use vkrad::formfactor::analytic::point_to_polygon;

use crate::common;

/// A UV sphere of radius 1 at the origin, `rings` x `segments` triangles'
/// worth (quads split in two), outward-facing.
fn sphere(rings: usize, segments: usize, material: usize) -> Vec<vkrad::scene::Patch> {
    let point = |i: usize, j: usize| {
        let theta = std::f32::consts::PI * i as f32 / rings as f32;
        let phi = 2.0 * std::f32::consts::PI * j as f32 / segments as f32;
        Vec3::new(
            theta.sin() * phi.cos(),
            theta.cos(),
            theta.sin() * phi.sin(),
        )
    };
    let mut patches = Vec::new();
    for i in 0..rings {
        for j in 0..segments {
            let (a, b, c, d) = (
                point(i, j),
                point(i + 1, j),
                point(i + 1, j + 1),
                point(i, j + 1),
            );
            // Counter-clockwise seen from outside.
            for tri in [[a, d, c], [a, c, b]] {
                let n = (tri[1] - tri[0]).cross(tri[2] - tri[0]);
                if n.length() > 1e-7 {
                    let tri = if n.dot(tri[0]) < 0.0 {
                        [tri[0], tri[2], tri[1]]
                    } else {
                        tri
                    };
                    patches.push(common::polygon(&tri, material));
                }
            }
        }
    }
    patches
}

#[test]
fn a_tessellated_sphere_shades_each_facet_by_its_own_plane() {
    let device = common::device();
    let mut patches = sphere(24, 48, 0);
    let triangles = patches.len();
    // A 1 x 1 light 3 above the centre, facing down.
    let light = [
        Vec3::new(-0.5, 3.0, -0.5),
        Vec3::new(0.5, 3.0, -0.5),
        Vec3::new(0.5, 3.0, 0.5),
        Vec3::new(-0.5, 3.0, 0.5),
    ];
    patches.push(common::polygon(&light, 1));
    let scene = common::scene(
        patches,
        vec![common::material(0.6, 0.0), common::material(0.0, 1.0)],
    );
    let mut job = Job::new("sphere");
    let dir = std::env::temp_dir().join(format!("vkrad-sphere-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    job.output = Some(dir.join("sphere.png"));
    job.size = (64, 64);
    // What the display mesh shows (the pixels' own test is `pixels`).
    job.shade = vkrad::gather::pixels::Shade::Mesh;
    // Every vertex is looked at, not just those the image shows.
    job.gather_unseen = true;
    let report = run_scene(&job, scene, 0.0, Some(device.clone()), |_| true).unwrap();
    let mesh = report.display_mesh.as_ref().unwrap_or(&report.mesh);
    let light: Vec<DVec3> = light.iter().map(|v| v.as_dvec3()).collect();
    let e = std::f64::consts::PI; // emission radiance 1: E = pi
    let (mut checked, mut worst) = (0, 0.0f64);
    // And how far the smooth normal's irradiance is from the facets' (what
    // one value per group showed).
    let mut facets_apart = 0.0f64;
    for element in &mesh.elements {
        for &v in element.corners() {
            let p = mesh.vertices[v as usize].as_dvec3();
            // The upper cap, where the whole light is above the tangent
            // plane.
            if p.y < 0.5 || (p.length() - 1.0).abs() > 1e-4 {
                continue;
            }
            let facet = element.normal.as_dvec3();
            let exact = 0.6 * e * point_to_polygon(p, facet, &light);
            let b = report.vertex_radiosity[v as usize][0] as f64;
            worst = worst.max((b - exact).abs() / exact);
            let smooth = 0.6 * e * point_to_polygon(p, p.normalize(), &light);
            facets_apart = facets_apart.max((smooth - exact).abs() / exact);
            checked += 1;
        }
    }
    eprintln!(
        "the smooth normal's irradiance is up to {:.2}% from the facets'",
        100.0 * facets_apart
    );
    eprintln!(
        "{triangles} triangles, {checked} corners on the cap: worst relative error {:.3}%",
        100.0 * worst
    );
    assert!(checked > 100, "{checked} corners checked");
    // The check can tell one from the other.
    assert!(
        facets_apart > 0.02,
        "facets {:.2}% apart",
        100.0 * facets_apart
    );
    assert!(
        worst < 0.02,
        "worst vertex off the smooth irradiance by {:.2}%",
        100.0 * worst
    );
    std::fs::remove_dir_all(&dir).ok();
    common::assert_validation_clean(&device);
}
