//! A-posteriori refinement and the gathered reference it is judged by: the
//! gather agrees with the solver where both are defined, the refinement's
//! own error estimate falls pass by pass, and at an equal element count the
//! refined discontinuity mesh's image is well closer to the reference than
//! a uniform mesh's.

use crate::common;

use std::path::PathBuf;

use vkrad::app::{run, Job};
use vkrad::bench::meshers::gathered_reference;
use vkrad::bench::relative_rms_error_where;
use vkrad::formfactor::gather::{GatherRays, Gatherer};
use vkrad::mesh::build::{build_mesh, MeshSettings, Mesher};
use vkrad::mesh::discontinuity::ShadowDetail;
use vkrad::output::image_io::{save_image, HdrImage};
use vkrad::solve::{solve, FormFactorMethod, Progress, SolveSettings};

fn ray_traced() -> SolveSettings {
    SolveSettings {
        method: FormFactorMethod::RayTrace { rays: 64 },
        converge: 1e-4,
        ..Default::default()
    }
}

#[test]
fn gather_reproduces_the_solver_at_its_vertices() {
    let device = common::device();
    let scene = vkrad::scene::load_builtin("simple").unwrap().unwrap();
    let settings = MeshSettings {
        mesher: Mesher::Uniform,
        max_edge: scene.extent() / 16.0,
        dm_res: 128,
        detail: ShadowDetail::Full,
    };
    let (mesh, _) = build_mesh(&device, &scene, &settings).unwrap();
    let solution = solve(
        &device,
        &scene,
        &mesh,
        &ray_traced(),
        &mut |_: &Progress| true,
    )
    .unwrap();
    let at_vertices = solution.vertex_radiosity.clone().unwrap();
    let gatherer = Gatherer::new(&scene, &mesh, &solution.radiosity, GatherRays::default());
    let brightest = at_vertices.iter().map(|b| b[0]).fold(0.0f32, f32::max);
    let (mut checked, mut close) = (0, 0);
    for e in &mesh.elements {
        for &v in e.corners() {
            let solver = at_vertices[v as usize][0];
            if solver < 1e-3 * brightest {
                continue;
            }
            let gathered = gatherer
                .radiosity_at(mesh.vertices[v as usize], e.patch, 1)
                .x;
            // Unoccluded, both are exact (the solver evaluates a hair inside
            // the patch, VERTEX_INSET); in penumbrae they differ by the
            // noise of 64 stratified rays, other random numbers.
            let relative = (gathered - solver).abs() / solver;
            assert!(
                relative <= 0.05,
                "vertex {v}: gathered {gathered}, solver {solver}"
            );
            checked += 1;
            close += usize::from(relative <= 2e-3);
        }
    }
    assert!(checked > 100, "only {checked} lit vertices");
    assert!(
        close * 10 >= checked * 8,
        "only {close} of {checked} lit vertices agree within 0.2%"
    );
    common::assert_validation_clean(&device);
}

fn failure_dir() -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("adaptive");
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn save(image: &HdrImage, name: &str) -> PathBuf {
    let path = failure_dir().join(name);
    save_image(image, &path, None).unwrap();
    path
}

fn difference(a: &HdrImage, b: &HdrImage) -> HdrImage {
    HdrImage {
        width: a.width,
        height: a.height,
        pixels: a
            .pixels
            .iter()
            .zip(&b.pixels)
            .map(|(x, y)| [0, 1, 2].map(|c| (x[c] - y[c]).abs()))
            .collect(),
    }
}

#[test]
fn adaptive_discontinuity_mesh_beats_uniform_at_equal_element_count() {
    let device = common::device();
    let scene = vkrad::scene::load_builtin("simple").unwrap().unwrap();
    let (reference, _) = gathered_reference(&device, &scene, true).unwrap();
    let out = failure_dir();
    let render = |mesher: Mesher, max_edge: f32, budget: Option<usize>| {
        let mut job = Job::new("simple");
        job.output = Some(out.join(format!("{mesher:?}.hdr").replace([' ', '{', '}', ':'], "")));
        job.size = (120, 80);
        job.mesher = mesher;
        job.max_edge = Some(max_edge);
        job.solve = ray_traced();
        // The meshes' own vertex values: this compares meshers, not the
        // final gather (which would shade a finer display mesh).
        job.final_gather = None;
        if let Some(n) = budget {
            job.adaptive = 8;
            job.tolerance = 0.0;
            job.max_elements = Some(n);
        }
        run(&job, Some(device.clone()), |_| true).unwrap()
    };
    let uniform = render(Mesher::Uniform, scene.extent() / 16.0, None);
    let n = uniform.mesh.elements.len();
    let adaptive = render(
        Mesher::Discontinuity { subdivide: false },
        scene.extent() / 4.0,
        Some(n),
    );
    let error = |image: &HdrImage| {
        relative_rms_error_where(image, &reference.image, Some(&reference.shading)).unwrap()
    };
    let (e_uniform, e_adaptive) = (error(&uniform.image), error(&adaptive.image));
    eprintln!(
        "uniform {n} elements: error {e_uniform:.4}; adaptive {} elements (passes {:?}, estimates {:?}): error {e_adaptive:.4}",
        adaptive.mesh.elements.len(),
        adaptive.adaptive_elements,
        adaptive.adaptive_errors
    );
    let m = adaptive.mesh.elements.len();
    assert!(
        m <= n && m * 10 >= n * 9,
        "{m} elements against a budget of {n}"
    );
    let estimates = &adaptive.adaptive_errors;
    assert!(
        estimates.len() >= 3 && estimates.last() < estimates.first(),
        "estimated error should fall pass by pass: {estimates:?}"
    );
    if e_adaptive >= 0.5 * e_uniform {
        let paths = [
            save(&reference.image, "reference.hdr"),
            save(&uniform.image, "uniform.hdr"),
            save(&adaptive.image, "adaptive.hdr"),
            save(
                &difference(&adaptive.image, &reference.image),
                "adaptive-diff.hdr",
            ),
            save(
                &difference(&uniform.image, &reference.image),
                "uniform-diff.hdr",
            ),
        ];
        panic!(
            "adaptive discontinuity mesh error {e_adaptive:.4} is not well below uniform's {e_uniform:.4} at {n} elements; images: {paths:?}"
        );
    }
    common::assert_validation_clean(&device);
}
