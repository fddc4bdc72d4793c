//! The final gather shades only the display elements the image shows
//! (`render::seen_elements`): nothing the camera sees is left out, what it
//! cannot see is, and the image is the one gathering everything gives.

use glam::Vec3;
use vkrad::app::{run_scene, Job};
use vkrad::scene::Camera;

use crate::common;

#[test]
fn an_element_behind_another_is_not_seen_and_the_front_one_is() {
    let device = common::device();
    // Two unit squares facing +z, one at z = 0 and one hidden behind it at
    // z = -1, and a third off to the side, outside the view.
    let square = |x: f32, z: f32| {
        common::polygon(
            &[
                Vec3::new(x - 0.5, -0.5, z),
                Vec3::new(x + 0.5, -0.5, z),
                Vec3::new(x + 0.5, 0.5, z),
                Vec3::new(x - 0.5, 0.5, z),
            ],
            0,
        )
    };
    let scene = common::scene(
        vec![square(0.0, 0.0), square(0.0, -1.0), square(40.0, 0.0)],
        vec![common::material(0.5, 0.0)],
    );
    let mesh = vkrad::mesh::uniform(&scene, 0.25);
    let camera = Camera {
        eye: Vec3::new(0.0, 0.0, 3.0),
        look_at: Vec3::ZERO,
        up: Vec3::Y,
        fov_y_deg: 40.0,
    };
    // A wide image: two windows side by side.
    let seen = vkrad::render::seen_elements(&device, &scene, &mesh, &camera, (96, 40)).unwrap();
    common::assert_validation_clean(&device);
    for (p, range) in mesh.patch_elements.iter().enumerate() {
        let of_patch = &seen[range.start as usize..range.end as usize];
        match p {
            0 => assert!(
                of_patch.iter().all(|&s| s),
                "the front square is seen whole"
            ),
            _ => assert!(
                of_patch.iter().all(|&s| !s),
                "patch {p} is hidden or out of view"
            ),
        }
    }
}

#[test]
fn gathering_only_the_shown_elements_leaves_the_image_as_it_was() {
    let device = common::device();
    let dir = common::Scratch::new("shown");
    let image_of = |gather_unseen: bool| {
        let mut job = Job::new("simple");
        job.output = Some(dir.join(format!("unseen-{gather_unseen}.exr")));
        job.size = (48, 48);
        // What the display mesh shows (the pixels' own test is `pixels`).
        job.shade = vkrad::gather::pixels::Shade::Mesh;
        job.gather_unseen = gather_unseen;
        // Refinement picks its elements by their level against the mean of
        // those it looks at: without it both runs gather the same mesh.
        job.display_refinements = 0;
        let scene = vkrad::scene::load_scene_arg("simple").unwrap();
        run_scene(&job, scene, 0.0, Some(device.clone()), |_| true).unwrap()
    };
    let (shown, all) = (image_of(false), image_of(true));
    common::assert_validation_clean(&device);
    let elements = shown.display_mesh.as_ref().unwrap().elements.len();
    let n = shown
        .shown_elements
        .expect("the shown elements are counted");
    assert!(n > 0 && n < elements, "{n} of {elements} shown");
    assert_eq!(all.shown_elements, None);
    assert_eq!(all.display_mesh.as_ref().unwrap().elements.len(), elements);
    // The same vertices are gathered but for the hidden ones, whose rays
    // differ only as each point's random stream is its place in the list.
    let (a, b) = (&shown.image.pixels, &all.image.pixels);
    let mean = b.iter().flatten().sum::<f32>() / (3 * b.len()) as f32;
    let squared: f32 = a
        .iter()
        .zip(b)
        .flat_map(|(x, y)| (0..3).map(move |c| (x[c] - y[c]).powi(2)))
        .sum();
    let rms = (squared / (3 * b.len()) as f32).sqrt() / mean;
    eprintln!(
        "{n} of {elements} elements shown; image difference {:.3}%",
        100.0 * rms
    );
    assert!(rms < 0.01, "relative RMS difference {:.3}%", 100.0 * rms);
}
