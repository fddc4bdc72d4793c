//! The final gather at the vertices the image shows: every mesh vertex's
//! radiosity gathered from the solved elements,
//! `B(v) = E(v) + rho(v) sum_s B_s F(v -> s) V(v, s)`, each `F` the exact
//! point-to-polygon form factor and `V` the ray-traced visible share of it.
//!
//! Why: averaging the neighbouring elements (what a progressive solve
//! gives per vertex) is biased exactly where people look. At a patch
//! boundary, a corner or a contact line the average comes from elements
//! that lie on one side, a vertex under a box takes half its value from
//! the lit element beside it (a light leak), and a penumbra is smeared over
//! two elements. Gathered at the vertex itself, each value is the light
//! that point receives, so the mesh only decides how the image
//! interpolates between correct values.
//!
//! Cost: the sources are the shooting hierarchy's nodes, opened like a
//! Barnes-Hut tree. A node is taken whole when it looks small from the
//! vertex (radius under [`VertexGather::opening`] times its distance) and
//! its elements' radiosity is even (within [`VertexGather::uniformity`] of
//! each other); otherwise its children are visited. Near and uneven light
//! is thus gathered element by element and far, even light in large
//! pieces: a vertex visits O(log n) nodes per patch, not n elements.
//! Emitting nodes get many stratified rays (their shadows are what the
//! image must resolve), reflecting ones a few, in proportion to their form
//! factor.
//!
//! In a scene of many small patches the reflected light is gathered by
//! rays sent over each point's hemisphere instead ([`hemisphere_rays`]);
//! the emitters stay exact.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, OnceLock};

use glam::Vec3;

use self::clusters::Clusters;
use self::exposure::{exposed_parts, EXPOSURE_GRID};
pub use self::gpu_direct::DirectLight;
use self::gpu_direct::GpuDirect;
use self::gpu_rays::{upload_bvh, GpuRays};
#[cfg(any(test, feature = "internals"))]
pub use self::hemisphere_rays::HEMISPHERE_RAYS;
use self::hemisphere_rays::{HemisphereRays, CENTRE_RAYS_SHARE, LANDING_EXPOSURE_GRID};
use self::links::Links;
pub use self::links::LINKS_BUDGET;
use self::lit_samples::DirectMeans;
use self::lit_samples::Emitters;
use self::point_gather::Linking;
use self::reflected_cache::HarmonicDistance;
use self::reflected_cache::{centre_records, ReflectedCache};
pub use self::settings::{PointLight, VertexGather, PIXEL_EMITTER_RAYS};
use self::settings::{CLOSE_FF, MIN_REFLECTOR_RAYS, NEAR_RADIUS};
use self::shared_centres::SharedCentres;
use self::sources::{sources, Source};
use self::tail::Passes;
pub use self::vertices::{Probed, VertexCache};
use crate::solve::hierarchy::ShooterTree;

use crate::formfactor::raytrace::Occluders;
use crate::gpu::rays::GpuBvh;
use crate::gpu::Device;
use crate::mesh::Mesh;
use crate::scene::Scene;
use crate::trace::{step, Trace};

/// Seeds every point's rays (its place in its list the stream).
const RANDOM_SEED: u64 = 0x005e_ed0f_9a7e;

/// What both passes share.
struct Gather<'a> {
    scene: &'a Scene,
    tree: &'a ShooterTree,
    sources: Vec<Source>,
    occluders: Occluders,
    clusters: Clusters,
    settings: VertexGather,
    /// Mean reflectance per patch and per solved element (textures
    /// averaged over each): a point's value is its patch's, an element's
    /// its own.
    patch_rho: Vec<Vec3>,
    element_rho: Vec<Vec3>,
    /// The last pass's reflected light at the element centres, for the
    /// display points (`None` during the passes).
    reflected_cache: Option<ReflectedCache>,
    /// Points since the cache was built that took their reflected light
    /// from it, and that gathered it.
    reused: [AtomicUsize; 2],
    /// The direct light's pass on the GPU, when asked for.
    gpu_direct: Option<GpuDirect>,
    /// The emitters a point's direct light is traced to where no exposed
    /// point holds it ([`lit_samples`](super::lit_samples)).
    emitters: Emitters,
    /// The direct light on each element, at its exposed points (`Some`:
    /// near reflecting sources lend it at their samples), and how much the
    /// emitters' light has grown since (by what they reflect).
    direct_map: Option<Arc<DirectMeans>>,
    direct_scale: Vec3,
    /// The patches whose light hemisphere rays gather.
    hemisphere_rays: HemisphereRays,
    /// The GPU pass that traces the first-hit rays (the hemisphere
    /// rays, the camera rays), when asked for.
    gpu_rays: Option<GpuRays>,
}

/// A point's gathered light, split by the kind of source.
#[derive(Debug, Clone, Copy)]
struct Gathered {
    /// Sum of B F V over emitting sources.
    direct: Vec3,
    /// ... and over the others.
    reflected: Vec3,
    /// How far the reflecting sources are.
    distance: HarmonicDistance,
    /// The distance to the nearest surface met (measured only when
    /// recording).
    clearance: f32,
    /// The standard error of the luminance of the light its first
    /// hemisphere rays read (part of `reflected`), from their spread; 0
    /// without.
    ray_error: f32,
    /// ... and of what all its hemisphere rays read, the more rays a
    /// noisy point sent included.
    reflected_error: f32,
    /// How the light its hemisphere rays read changes as its normal turns.
    reflected_turn: hemisphere_rays::ReflectedTurn,
}

/// Radiosity at every vertex of `display`, gathered from the element
/// radiosity `radiosity` of the solved mesh `solved` (one rgb value per
/// element: what the solve shows for it, ambient term included; `tree` is
/// `solved`'s hierarchy). `display` may be `solved` itself or a finer mesh
/// of the same scene. Vertices no element uses get 0.
///
/// # Panics
/// If `radiosity.len() != solved.elements.len()`.
#[cfg(any(test, feature = "internals"))]
pub fn gather_vertices(
    scene: &Scene,
    solved: &Mesh,
    tree: &ShooterTree,
    radiosity: &[[f32; 3]],
    display: &Mesh,
    settings: &VertexGather,
) -> Vec<[f32; 3]> {
    FinalGather::new(scene, solved, tree, radiosity, settings)
        .at_vertices(display, &mut VertexCache::default())
}

/// Counts the points gathered, for a progress display: `tick(done,
/// total)` is called between chunks of points and returns false to stop
/// (an interrupt), which makes the metered calls return `None`. A caller
/// counts a mesh's vertices in `total` before gathering at them; the
/// gather takes back those that smooth groups and the cache spare.
pub struct Meter<'a> {
    pub done: usize,
    pub total: usize,
    /// `None`: count, never stop.
    tick: Option<&'a mut dyn FnMut(usize, usize) -> bool>,
    /// The run's trace: each chunk's work per rayon worker becomes a span.
    pub trace: Option<&'a Trace>,
}

impl<'a> Meter<'a> {
    pub fn new(total: usize, tick: &'a mut dyn FnMut(usize, usize) -> bool) -> Self {
        Meter {
            done: 0,
            total,
            tick: Some(tick),
            trace: None,
        }
    }

    /// A meter that reports to no one and never stops.
    pub fn unwatched() -> Meter<'static> {
        Meter {
            done: 0,
            total: 0,
            tick: None,
            trace: None,
        }
    }

    /// Counts `points` more; false: stop. Counting none reports nothing
    /// (work too quick to show, such as the passes over recorded links).
    fn advance(&mut self, points: usize) -> bool {
        if points == 0 {
            return true;
        }
        self.done += points;
        self.total = self.total.max(self.done);
        match &mut self.tick {
            Some(tick) => tick(self.done, self.total),
            None => true,
        }
    }
}

/// Points gathered between two progress ticks: a fraction of a second on
/// two cores at the cost per point of a large scene (about 1 ms), and
/// enough to keep every core busy.
const CHUNK: usize = 1024;

/// The solved elements made ready to be gathered from: sources undiluted,
/// corrected by the Jacobi passes.
pub struct FinalGather<'a> {
    gather: Gather<'a>,
    /// Why the GPU did not gather the direct light though asked to.
    gpu_refused: Option<String>,
    /// The element centres it traced rays from (each once; fewer than
    /// the elements where they share, [`shared_centres`]).
    centres_gathered: usize,
    /// The return ratio whose tail of bounces was added after the last
    /// pass ([`tail`]), if one was.
    tail_ratio: Option<f64>,
    /// The scene's smooth surfaces, found once for whoever asks first.
    surfaces: OnceLock<Vec<u32>>,
    /// The emitters as the display's facets turn to them, found once.
    facet_turn: OnceLock<facets::FacetTurn>,
    /// Display points that pooled their rays, and those of them that
    /// sent them all ([`shared_reflected`]).
    pooled: [usize; 2],
}

impl<'a> FinalGather<'a> {
    /// Builds the sources from the solved `radiosity` and runs
    /// `settings.source_passes` Jacobi passes at the element centres.
    ///
    /// # Panics
    /// If `radiosity.len() != solved.elements.len()`.
    pub fn new(
        scene: &'a Scene,
        solved: &Mesh,
        tree: &'a ShooterTree,
        radiosity: &[[f32; 3]],
        settings: &VertexGather,
    ) -> Self {
        Self::metered(
            scene,
            solved,
            tree,
            radiosity,
            settings,
            None,
            &mut Meter::unwatched(),
        )
        .expect("an unwatched meter never stops")
    }

    /// [`FinalGather::new`], counting the passes' points on `meter`;
    /// `None` when it stops them. With `device`, the emitters' direct
    /// light is gathered there as [`VertexGather::direct_light`] says.
    /// Without, on the CPU.
    pub fn metered(
        scene: &'a Scene,
        solved: &Mesh,
        tree: &'a ShooterTree,
        radiosity: &[[f32; 3]],
        settings: &VertexGather,
        device: Option<&Arc<Device>>,
        meter: &mut Meter,
    ) -> Option<Self> {
        assert_eq!(radiosity.len(), solved.elements.len());
        let trace = meter.trace;
        let occluders = step(trace, "ray-tracing hierarchy", || Occluders::new(scene));
        // A solved element partly under a box has its light spread over its
        // whole area, the covered part included: the part that shows is
        // brighter than that mean by 1 / (exposed share).
        // In a scene of small patches hemisphere rays gather the reflected
        // light (and read the direct light at the exposed points); the
        // clusters and the exact gather take the rest.
        let hemisphere_rays = HemisphereRays::new(scene, tree, settings.hemisphere_rays);
        let grid = match hemisphere_rays.any() {
            true => LANDING_EXPOSURE_GRID,
            false => EXPOSURE_GRID,
        };
        let exposed = step(trace, "exposed parts", || {
            exposed_parts(scene, solved, &occluders, grid)
        });
        let undiluted: Vec<[f32; 3]> = radiosity
            .iter()
            .zip(&exposed)
            .map(|(b, part)| match part.share {
                s if s > 0.0 => (Vec3::from(*b) / s).to_array(),
                _ => [0.0; 3],
            })
            .collect();
        let first = sources(scene, solved, tree, &undiluted, &exposed, None);
        let roots = tree.roots();
        let exact_roots: Vec<u32> = roots
            .iter()
            .copied()
            .filter(|&n| !hemisphere_rays.gathers(tree.nodes[n as usize].patch))
            .collect();
        let mut gather = Gather {
            scene,
            tree,
            clusters: Clusters::new(tree, &exact_roots, &first),
            sources: first,
            occluders,
            settings: *settings,
            patch_rho: scene.patch_reflectances(),
            element_rho: solved.element_reflectance(scene),
            reflected_cache: None,
            reused: [AtomicUsize::new(0), AtomicUsize::new(0)],
            gpu_direct: None,
            emitters: Emitters::default(),
            direct_map: None,
            direct_scale: Vec3::ONE,
            hemisphere_rays,
            gpu_rays: None,
        };
        let mut gpu_refused = None;
        // One BVH on the GPU for both passes, uploaded when one wants it.
        let mut bvh = None;
        let mut upload = |device: &Arc<Device>| -> crate::error::Result<Arc<GpuBvh>> {
            if bvh.is_none() {
                bvh = Some(upload_bvh(device, scene)?);
            }
            Ok(Arc::clone(bvh.as_ref().expect("uploaded")))
        };
        let refusal = |what: &str, e: crate::error::Error| {
            format!("the GPU cannot {what} ({e}); the CPU did")
        };
        if let Some(device) = device.filter(|d| settings.ray_device.on_gpu(d)) {
            match upload(device).and_then(|bvh| GpuRays::new(device, bvh)) {
                Ok(pass) => gather.gpu_rays = Some(pass),
                Err(e) => gpu_refused = Some(refusal("trace the first-hit rays", e)),
            }
        }
        if let Some(device) = device.filter(|d| settings.direct_light.on_gpu(d)) {
            match upload(device).and_then(|bvh| GpuDirect::new(device, bvh)) {
                Ok(gpu) => gather.gpu_direct = Some(gpu),
                Err(e) => gpu_refused = Some(refusal("gather the direct light", e)),
            }
        }
        gather.emitters_to_gpu(&roots, &mut gpu_refused);
        // Each pass at the elements (the centre of their exposed part) is a
        // Jacobi step with exact form factors: it corrects the solve's
        // element values (biased where its form factors are, on coarse
        // elements) by the share rho that comes back.
        let frames: Vec<Frame> = solved
            .elements
            .iter()
            .zip(&exposed)
            .map(|(e, part)| (part.centre, e.normal, e.patch))
            .collect();
        // The first pass records each centre's links; the later ones are
        // sparse products over them ([`links`]). With the reflected cache,
        // the first pass also measures how far each centre's light holds,
        // and the cache's records take their light from the final sources.
        // The emitters' light on each element, averaged over its exposed
        // part, and lent at their samples by near sources
        // ([`lit_samples`]). Without passes the sources keep the light
        // they were given.
        let direct_means = (settings.source_passes > 0).then(|| {
            gather.emitters = Emitters::new(&gather, &roots);
            let means = step(trace, "direct means", || {
                let landing = gather.hemisphere_rays.any().then_some(grid);
                gather.direct_means(solved, &exposed, landing)
            });
            let means = Arc::new(means);
            let lit = Some((&*means, &gather.element_rho[..]));
            gather.sources = sources(scene, solved, tree, &undiluted, &exposed, lit);
            gather.direct_map = Some(Arc::clone(&means));
            means
        });
        // With each element's direct light known, the small elements of a
        // smooth surface share their gathers of the rest
        // ([`shared_centres`]).
        let surfaces = OnceLock::new();
        let shared = direct_means
            .as_ref()
            .map(|_| {
                let surface = surfaces.get_or_init(|| scene.smooth_surfaces());
                SharedCentres::new(solved, &exposed, surface)
            })
            .filter(|s| !s.is_trivial());
        let leaders = shared.as_ref().map(|s| {
            let skipped = (frames.len() - s.leaders.len()) * settings.centre_gathers();
            meter.total = meter.total.saturating_sub(skipped);
            (s.at_leaders(&frames), s.leader_rho(&gather.element_rho))
        });
        // One pass's (or the records') gather at every centre, through
        // the leaders where they share.
        let gather_centres = |gather: &Gather,
                              rho: Option<&[Vec3]>,
                              measure: Option<bool>,
                              linking: Linking,
                              known: Option<&[Vec3]>,
                              meter: &mut Meter| {
            match (&shared, &leaders) {
                (Some(shared), Some((frames, leader_rho))) => {
                    let known_there = known.map(|k| shared.at_leaders(k));
                    let rho = rho.map(|_| &leader_rho[..]);
                    let gathered = gather.gather_points(
                        frames,
                        rho,
                        measure,
                        linking,
                        known_there.as_deref(),
                        meter,
                    )?;
                    let rho = &gather.element_rho;
                    Some(shared.spread(scene, solved, rho, &gathered, known))
                }
                _ => gather.gather_points(&frames, rho, measure, linking, known, meter),
            }
        };
        let mut links: Vec<Option<Links>> = Vec::new();
        let mut reach: Option<Vec<f32>> = None;
        let mut noise: Option<Vec<f32>> = None;
        let record = (settings.reuse > 0.0).then_some(true);
        // The centres' light is averaged again by every point that gathers
        // from them: half the rays do there ([`CENTRE_RAYS_SHARE`]).
        gather
            .hemisphere_rays
            .set_rays((settings.hemisphere_rays / CENTRE_RAYS_SHARE).max(1));
        // The bounces the last pass leaves out ([`tail`]).
        let (mut history, mut tail_ratio) = (Passes::default(), None);
        let areas: Vec<f32> = solved.elements.iter().map(|e| e.area).collect();
        for pass in 0..settings.source_passes {
            let linking = match pass {
                0 => Linking::Record(&mut links),
                _ => Linking::Replay(&links),
            };
            // Only the first pass measures how far the light holds.
            let measure = record.filter(|_| pass == 0);
            let rho = Some(&gather.element_rho[..]);
            let known: Option<Vec<Vec3>> = direct_means
                .as_ref()
                .map(|m| m.mean.iter().map(|&d| d * gather.direct_scale).collect());
            let known = known.as_deref();
            let gathered = gather_centres(&gather, rho, measure, linking, known, meter)?;
            if measure.is_some() {
                reach = Some(gathered.iter().map(|(_, g)| g.reach()).collect());
                noise = Some(gathered.iter().map(|(_, g)| g.ray_noise()).collect());
            }
            let mut corrected: Vec<[f32; 3]> = gathered.iter().map(|(b, _)| b.to_array()).collect();
            for (b, part) in corrected.iter_mut().zip(&exposed) {
                if part.share <= 0.0 {
                    *b = [0.0; 3];
                }
            }
            history.push(&corrected);
            if pass + 1 == settings.source_passes {
                tail_ratio = history.add_tail(&mut corrected, &areas);
            }
            let lit = direct_means
                .as_ref()
                .map(|m| (&**m, &gather.element_rho[..]));
            gather.sources = sources(scene, solved, tree, &corrected, &exposed, lit);
            if let Some(means) = &direct_means {
                gather.follow_emitters(means);
            }
            gather.clusters.relight(&gather.sources);
            gather.emitters_to_gpu(&roots, &mut gpu_refused);
        }
        if settings.reuse > 0.0 {
            // Only the reflected light, from the final sources: by the
            // links where there are, gathered again where not (no passes,
            // or past the links' budget).
            let linking = Linking::Replay(&links);
            let rho = Some(&gather.element_rho[..]);
            let gathered = gather_centres(&gather, rho, Some(false), linking, None, meter)?;
            let reach = reach.unwrap_or_else(|| gathered.iter().map(|(_, g)| g.reach()).collect());
            let noise =
                noise.unwrap_or_else(|| gathered.iter().map(|(_, g)| g.ray_noise()).collect());
            let records = centre_records(
                &frames,
                &gathered,
                (&reach, &noise),
                settings.ray_noise,
                &exposed,
                solved,
            );
            gather.reflected_cache = Some(ReflectedCache::new(records, settings.reuse));
        }
        gather.hemisphere_rays.set_rays(settings.hemisphere_rays);
        let centres_gathered = match (settings.centre_gathers(), &shared) {
            (0, _) => 0,
            (_, Some(shared)) => shared.leaders.len(),
            (_, None) => frames.len(),
        };
        Some(FinalGather {
            gather,
            gpu_refused,
            centres_gathered,
            tail_ratio,
            surfaces,
            facet_turn: OnceLock::new(),
            pooled: [0; 2],
        })
    }

    /// Radiosity at arbitrary points `(point, normal, patch)` on the front
    /// of their patch.
    pub fn at_points(&self, frames: &[(Vec3, Vec3, u32)]) -> Vec<[f32; 3]> {
        self.gather
            .at_points(frames, None, &mut Meter::unwatched())
            .expect("an unwatched meter never stops")
    }

    /// Why the direct light was gathered on the CPU though the GPU was
    /// asked to (or stopped doing it part of the way).
    pub fn gpu_warning(&self) -> Option<String> {
        let failed = self
            .gather
            .gpu_direct
            .as_ref()
            .and_then(|g| g.failure.lock().unwrap_or_else(|e| e.into_inner()).clone());
        self.gpu_refused.clone().or(failed)
    }

    /// Whether the GPU gathers the emitters' direct light.
    pub fn direct_on_gpu(&self) -> bool {
        self.gather.gpu_direct.is_some()
    }

    /// Whether the reflected light is gathered by hemisphere rays
    /// ([`hemisphere_rays`]: a scene of small patches).
    pub fn by_hemisphere_rays(&self) -> bool {
        self.gather.hemisphere_rays.any()
    }

    /// Per patch, its smooth surface ([`Scene::smooth_surfaces`]),
    /// found once per gather.
    pub fn smooth_surfaces(&self) -> &[u32] {
        self.surfaces
            .get_or_init(|| self.gather.scene.smooth_surfaces())
    }

    /// The element centres the passes traced rays from (each once).
    pub fn centres_gathered(&self) -> usize {
        self.centres_gathered
    }

    /// The return ratio of the bounces added after the last pass, if
    /// they were ([`tail`]).
    pub fn tail_ratio(&self) -> Option<f64> {
        self.tail_ratio
    }

    /// How many points so far took their reflected light from the
    /// element centres' cache, and how many gathered it themselves (both
    /// 0 without a cache).
    pub fn reflected_reuse(&self) -> (usize, usize) {
        let [reused, gathered] = &self.gather.reused;
        (
            reused.load(Ordering::Relaxed),
            gathered.load(Ordering::Relaxed),
        )
    }

    /// The scene's ray-tracing hierarchy the gather traces its rays in.
    pub fn occluders(&self) -> &Occluders {
        &self.gather.occluders
    }

    /// One kind of light at each frame ([`PointLight`]): `sum B_s F V`
    /// before the point's own reflectance, counted on `meter`; `None` when
    /// it stops them. Frame `i` traces random stream `first_stream + i`
    /// (points gathered in two calls take apart streams).
    pub fn light_at_points(
        &self,
        frames: &[(Vec3, Vec3, u32)],
        light: PointLight,
        first_stream: u64,
        meter: &mut Meter,
    ) -> Option<Vec<Vec3>> {
        self.gather.light_at(frames, light, first_stream, meter)
    }

    /// [`FinalGather::at_points`], counting them on `meter`, each with
    /// the standard error of its luminance from its hemisphere rays.
    pub fn at_points_metered(
        &self,
        frames: &[(Vec3, Vec3, u32)],
        meter: &mut Meter,
    ) -> Option<Vec<Probed>> {
        let gathered = self
            .gather
            .gather_points(frames, None, None, Linking::None, None, meter)?;
        Some(
            gathered
                .into_iter()
                .zip(frames)
                .map(|((b, g), frame)| Probed {
                    value: b.to_array(),
                    noise: self.reflectance_level(frame.2) * g.reflected_error,
                })
                .collect(),
        )
    }
}

/// Where a value is gathered: point, normal, patch (`u32::MAX`: none).
type Frame = (Vec3, Vec3, u32);

/// Whether light whose levels range over `lo..=hi` is even: the brightest
/// within `uniformity` of the dimmest (or all dark).
fn is_even(lo: f32, hi: f32, uniformity: f32) -> bool {
    hi <= uniformity * lo || hi <= 0.0
}

mod clusters;
pub mod display;
mod exposure;
mod facets;
mod gpu_direct;
mod gpu_rays;
mod hemisphere_rays;
mod links;
mod lit_samples;
mod many_lights;
pub mod pixels;
mod point_gather;
pub mod probe_fit;
mod receiver;
pub mod refine;
mod reflected_cache;
mod settings;
mod shared_centres;
mod shared_reflected;
mod sources;
mod tail;
#[cfg(test)]
mod tests;
mod vertices;
