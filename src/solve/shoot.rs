//! One shot of progressive refinement (thesis fig. 8): form factors from
//! the shooter to every receiver, by the GPU hemicube or a CPU method, then
//! the compute-shader update of every receiver's radiosity and unshot
//! radiosity. [`Shots`] hides which method made the form factors.

use std::collections::VecDeque;
use std::sync::Arc;
use std::time::Instant;

use super::hierarchy::ShooterTree;
use crate::error::{Error, Result};
use crate::formfactor::analytic::element_and_vertex_form_factors_analytic;
use crate::formfactor::hemicube::Hemicube;
use crate::formfactor::raytrace::RayTracedFormFactors;
use crate::gpu::item::ItemVertex;
use crate::gpu::shooting::{
    fixed_point_weights, BatchIds, BatchResult, ElementGeometry, HemicubeLayout, Region, Shooter,
    ShootingEngine, ShootingInputs, FRAMES,
};
use crate::gpu::{Device, StageTimes};
use crate::mesh::Mesh;
use crate::scene::Scene;

/// Where each shot's form factors come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FormFactorMethod {
    /// GPU hemicube at the shooter's centre (thesis 2.3.1).
    Hemicube,
    /// CPU rays from every receiver vertex to stratified points on the
    /// shooter (thesis 2.3.2, Wallace et al. 1989), `rays` per vertex.
    RayTrace { rays: usize },
    /// Exact point-to-polygon form factors at receiver vertices, ignoring
    /// occlusion: correct only for scenes where nothing blocks anything.
    Analytic,
}

impl FormFactorMethod {
    /// Rays per receiver vertex of [`FormFactorMethod::RayTrace`] unless tuned.
    pub const DEFAULT_RAYS: usize = 64;

    pub fn name(&self) -> String {
        match self {
            FormFactorMethod::Hemicube => "hemicube".into(),
            FormFactorMethod::RayTrace { rays } => format!("raytrace ({rays} rays)"),
            FormFactorMethod::Analytic => "analytic (unoccluded)".into(),
        }
    }
}

/// Geometry and materials of the mesh in the form the GPU passes take.
pub struct GpuMesh {
    pub triangles: Vec<ItemVertex>,
    pub reflectance_area: Vec<[f32; 4]>,
    pub emission: Vec<[f32; 4]>,
    pub geometry: Vec<ElementGeometry>,
    /// The shooting hierarchy (its order numbers the elements for the GPU).
    pub tree: ShooterTree,
}

impl GpuMesh {
    pub fn new(scene: &Scene, mesh: &Mesh) -> Self {
        let mut triangles = Vec::with_capacity(mesh.triangle_count() * 3);
        let mut reflectance_area = Vec::with_capacity(mesh.elements.len());
        let mut emission = Vec::with_capacity(mesh.elements.len());
        // Each element's mean reflectance (its Kd times its texture's mean).
        let rho = mesh.element_reflectance(scene);
        for (i, e) in mesh.elements.iter().enumerate() {
            for tri in e.triangles() {
                for v in tri {
                    triangles.push(ItemVertex {
                        position: mesh.vertices[v as usize].to_array(),
                        element: i as u32,
                    });
                }
            }
            let m = scene.patch_material(e.patch);
            reflectance_area.push(rho[i].extend(e.area).to_array());
            // Emitted radiosity E = pi * L_e.
            emission.push((m.emission * std::f32::consts::PI).extend(0.0).to_array());
        }
        let geometry = mesh
            .elements
            .iter()
            .map(|e| {
                let c = e.corners();
                ElementGeometry {
                    corners: std::array::from_fn(|k| {
                        mesh.vertices[c[k.min(c.len() - 1)] as usize]
                            .extend(0.0)
                            .to_array()
                    }),
                    normal_count: e.normal.extend(c.len() as f32).to_array(),
                }
            })
            .collect();
        GpuMesh {
            triangles,
            reflectance_area,
            emission,
            geometry,
            tree: ShooterTree::new(scene, mesh),
        }
    }

    /// Builds the GPU engine over this mesh.
    pub fn engine(&self, device: &Arc<Device>, hemicube: Hemicube) -> Result<ShootingEngine> {
        let hemicubes: Vec<HemicubeLayout> = hemicube
            .ladder()
            .into_iter()
            .map(|h| HemicubeLayout {
                res: h.res,
                atlas: h.atlas_size(),
                face_viewports: std::array::from_fn(|f| h.face_viewport(f)),
                weights: fixed_point_weights(&h.delta_form_factors()),
            })
            .collect();
        ShootingEngine::new(
            device,
            &ShootingInputs {
                triangles: &self.triangles,
                reflectance_area: &self.reflectance_area,
                initial_radiosity: &self.emission,
                geometry: &self.geometry,
                ranks: &self.tree.rank,
                hemicubes: &hemicubes,
            },
        )
    }
}

/// Distance below which the hemicube clips geometry, relative to the
/// shooter's size: small enough to lose no visible solid angle, large enough
/// for depth precision (reverse-Z keeps it fine near the eye).
fn near_plane(area: f32) -> f32 {
    1e-4 * area.sqrt()
}

/// Form factors computed on the CPU for one shooter at a time.
pub enum CpuFormFactors<'a> {
    RayTrace {
        tracer: Box<RayTracedFormFactors<'a>>,
        rays: usize,
    },
    Analytic {
        scene: &'a Scene,
        mesh: &'a Mesh,
    },
}

impl<'a> CpuFormFactors<'a> {
    /// `None` for the GPU hemicube.
    pub fn new(scene: &'a Scene, mesh: &'a Mesh, method: FormFactorMethod) -> Option<Self> {
        match method {
            FormFactorMethod::Hemicube => None,
            FormFactorMethod::RayTrace { rays } => Some(CpuFormFactors::RayTrace {
                tracer: Box::new(RayTracedFormFactors::new(scene, mesh)),
                rays,
            }),
            FormFactorMethod::Analytic => Some(CpuFormFactors::Analytic { scene, mesh }),
        }
    }

    /// F(shooter -> every element). `salt` varies the ray pattern per shot.
    pub fn shooter_row(&self, shooter: usize, salt: u64) -> Vec<f32> {
        self.shooter_row_with_vertices(shooter, salt).0
    }

    /// F(shooter -> every element), and for ray tracing also F(vertex <-
    /// shooter) at every vertex (Wallace's vertex-to-source values).
    pub fn shooter_row_with_vertices(
        &self,
        shooter: usize,
        salt: u64,
    ) -> (Vec<f32>, Option<Vec<f32>>) {
        match self {
            CpuFormFactors::RayTrace { tracer, rays } => {
                let seed = salt.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ shooter as u64;
                let (elements, vertices) = tracer.shooter_row_with_vertices(shooter, *rays, seed);
                (elements, Some(vertices))
            }
            CpuFormFactors::Analytic { scene, mesh } => {
                let (elements, vertices) =
                    element_and_vertex_form_factors_analytic(scene, mesh, shooter);
                (elements, Some(vertices))
            }
        }
    }

    pub fn stage_name(&self) -> &'static str {
        match self {
            CpuFormFactors::RayTrace { .. } => "ray-traced form factors (CPU)",
            CpuFormFactors::Analytic { .. } => "analytic form factors (CPU)",
        }
    }
}

/// What all the shots of a solve left behind.
pub struct ShotTotals {
    /// Radiosity per element (rgb).
    pub radiosity: Vec<[f32; 3]>,
    /// Radiosity per vertex, where the method computes it there.
    pub vertex_radiosity: Option<Vec<[f32; 3]>>,
    /// Time per stage of all shots.
    pub times: StageTimes,
}

/// Shoots from one element at a time, by any [`FormFactorMethod`], and
/// keeps what the method accumulates besides the GPU's element radiosity
/// (the CPU methods' radiosity at the vertices themselves).
pub struct Shots<'a> {
    mesh: &'a Mesh,
    hemicube: Hemicube,
    engine: ShootingEngine,
    /// The hemicube resolutions the engine has weight tables for, finest
    /// first.
    resolutions: Vec<u32>,
    cpu: Option<CpuFormFactors<'a>>,
    tree: ShooterTree,
    /// The mean reflectance of every vertex's patch (vertices belong to
    /// one patch): vertex values are radiosities at that reflectance.
    vertex_reflectance: Vec<glam::Vec3>,
    /// Radiosity at every vertex (CPU methods only: Wallace 1989).
    vertex_radiosity: Option<Vec<[f32; 3]>>,
    /// Batches submitted and not yet waited for, oldest first.
    pending: VecDeque<Pending>,
    /// The largest power one shot carried so far (mean channel).
    strongest_shot: f64,
    /// The coarsest hemicube resolution a shot may take
    /// ([`resolution_for`]'s floor): what resolves this mesh's elements
    /// ([`resolving_resolution`]), or beyond the finest when every shot
    /// takes the finest.
    min_resolution: u32,
    cpu_times: StageTimes,
}

/// A batch [`Shots::wait`] has still to return.
enum Pending {
    /// On the GPU: the nodes that shoot in it.
    Gpu(Vec<u32>),
    /// Shot already (a CPU method's shot is synchronous): its result.
    Done(Vec<[f32; 4]>, f64),
}

impl<'a> Shots<'a> {
    /// `hemicube_res`: the finest hemicube; `adapt_resolution`: dimmer
    /// shots may take coarser ones ([`resolution_for`]).
    pub fn new(
        device: &Arc<Device>,
        scene: &'a Scene,
        mesh: &'a Mesh,
        gpu_mesh: GpuMesh,
        method: FormFactorMethod,
        (hemicube_res, adapt_resolution): (u32, bool),
    ) -> Result<Self> {
        let hemicube = Hemicube::new(hemicube_res)?;
        let engine = gpu_mesh.engine(device, hemicube)?;
        let cpu = CpuFormFactors::new(scene, mesh, method);
        let mut vertex_patch = vec![0u32; mesh.vertices.len()];
        for e in &mesh.elements {
            for &v in e.corners() {
                vertex_patch[v as usize] = e.patch;
            }
        }
        let vertex_radiosity = cpu.as_ref().map(|_| {
            vertex_patch
                .iter()
                .map(|&p| (scene.patch_material(p).emission * std::f32::consts::PI).to_array())
                .collect()
        });
        let vertex_reflectance = match cpu {
            Some(_) => {
                let patch_rho = scene.patch_reflectances();
                vertex_patch
                    .iter()
                    .map(|&p| patch_rho[p as usize])
                    .collect()
            }
            None => Vec::new(),
        };
        Ok(Shots {
            mesh,
            hemicube,
            resolutions: engine.resolutions(),
            engine,
            cpu,
            // The engine holds its own copies: keep only the tree.
            tree: gpu_mesh.tree,
            vertex_reflectance,
            vertex_radiosity,
            pending: VecDeque::new(),
            strongest_shot: 0.0,
            min_resolution: if adapt_resolution {
                resolving_resolution(scene, mesh)
            } else {
                u32::MAX
            },
            cpu_times: StageTimes::default(),
        })
    }

    /// The shooting hierarchy over this mesh.
    pub fn tree(&self) -> &ShooterTree {
        &self.tree
    }

    /// How many batches may be in flight at once: with the GPU hemicube,
    /// the CPU prepares the next batch while the GPU shoots the last one;
    /// a CPU method's shot is done when it is submitted.
    pub fn depth(&self) -> usize {
        if self.cpu.is_some() {
            1
        } else {
            FRAMES
        }
    }

    /// Submits nodes `nodes` of the shooting hierarchy, to be shot in order
    /// in one GPU submission (a batch; see `gpu/shooting/batch.rs`); up to
    /// [`Self::depth`] batches may be pending, and [`Self::wait`] returns
    /// their results in order. Each node shoots the mean unshot radiosity
    /// over its elements when it shoots (read on the GPU) from its whole
    /// area; `unshot` (every element's value as last read back) places its
    /// hemicube and spreads its light over its parts. The nodes must be
    /// disjoint; the CPU methods take one leaf at a time. `region`: form
    /// factors are exact x visibility from the node's outline (hierarchical
    /// shooting); else the hemicube's own at its centre (element shooting,
    /// nodes are leaves). `salt` varies the CPU methods' ray pattern per
    /// shot. Returns the batch's ids (`None` for a CPU method's shot).
    pub fn submit(
        &mut self,
        nodes: &[u32],
        unshot: &[[f32; 4]],
        salt: u64,
        region: bool,
    ) -> Result<Option<BatchIds>> {
        if self.pending.len() >= self.depth() {
            return Err(Error::Invalid(format!(
                "{} shot batches are pending already: wait for one first",
                self.pending.len()
            )));
        }
        if self.cpu.is_some() {
            let &[node] = nodes else {
                return Err(Error::Invalid(
                    "ray-traced and analytic form factors shoot one element per submission".into(),
                ));
            };
            let (after, power) = self.shoot_cpu(node, unshot, salt)?;
            self.pending.push_back(Pending::Done(after, power));
            return Ok(None);
        }
        let (tree, mesh) = (&self.tree, self.mesh);
        // Per node: the parts' outlines and weights, which its Region borrows.
        let parts: Vec<Vec<(&[glam::Vec3], f32)>> = nodes
            .iter()
            .map(|&node| {
                if region && tree.nodes[node as usize].children.len() > 1 {
                    parts(tree, mesh, node, unshot)
                } else {
                    Vec::new()
                }
            })
            .collect();
        let mut shooters = Vec::with_capacity(nodes.len());
        for (&node, parts) in nodes.iter().zip(&parts) {
            let n = &tree.nodes[node as usize];
            let area = n.area.max(f32::MIN_POSITIVE);
            // A region's hemicube stands where its light leaves from; the
            // outline's radius is taken around that point.
            let light = unshot_light(tree, mesh, node, unshot);
            let (centre, radius) = if region {
                let radius = n.polygon.iter().map(|v| v.distance(light.centre));
                (light.centre, radius.fold(0.0, f32::max))
            } else {
                (n.centre, n.radius)
            };
            self.strongest_shot = self.strongest_shot.max(light.power);
            shooters.push(Shooter {
                faces: self
                    .hemicube
                    .face_view_proj(centre, n.normal, near_plane(area)),
                area: n.area,
                ranks: (n.range.start, n.range.end),
                resolution: resolution_for(
                    &self.resolutions,
                    light.power,
                    self.strongest_shot,
                    self.min_resolution,
                ),
                region: region.then_some(Region {
                    outline: &n.polygon,
                    centre,
                    radius,
                    normal: n.normal,
                    outline_area: n.polygon_area,
                    parts,
                }),
            });
        }
        let ids = self.engine.submit(&shooters)?;
        self.pending.push_back(Pending::Gpu(nodes.to_vec()));
        Ok(Some(ids))
    }

    /// Waits for the oldest pending batch: every element's unshot
    /// radiosity after it (rgba, a unused) and the power it shot (mean
    /// channel).
    pub fn wait(&mut self) -> Result<(Vec<[f32; 4]>, f64)> {
        match self.pending.pop_front() {
            None => Err(Error::Invalid("no shot batch is pending".into())),
            Some(Pending::Done(after, power)) => Ok((after, power)),
            Some(Pending::Gpu(nodes)) => {
                let BatchResult { unshot, shot_light } = self.engine.wait()?;
                Ok((unshot, self.shot_power(&nodes, &shot_light)))
            }
        }
    }

    /// The power (mean channel) the nodes shot, from the mean unshot
    /// radiosity each carried.
    fn shot_power(&self, nodes: &[u32], light: &[[f32; 3]]) -> f64 {
        nodes
            .iter()
            .zip(light)
            .map(|(&node, l)| {
                let area = self.tree.nodes[node as usize].area as f64;
                (l[0] as f64 + l[1] as f64 + l[2] as f64) / 3.0 * area
            })
            .sum()
    }

    /// One shot of a leaf with form factors from the CPU method.
    fn shoot_cpu(
        &mut self,
        node: u32,
        unshot: &[[f32; 4]],
        salt: u64,
    ) -> Result<(Vec<[f32; 4]>, f64)> {
        // One batch at a time: `unshot` is current, so the CPU's mean is
        // the light the GPU reads.
        let mean = unshot_light(&self.tree, self.mesh, node, unshot).mean;
        let n = &self.tree.nodes[node as usize];
        let ranks = (n.range.start, n.range.end);
        let area = n.area;
        let Some(shooter) = n.element else {
            return Err(Error::Invalid(
                "ray-traced and analytic form factors shoot element by element (--tune shooting element)"
                    .into(),
            ));
        };
        let Some(cpu) = &self.cpu else {
            return Err(Error::Invalid("no CPU form-factor method".into()));
        };
        let t = Instant::now();
        let (ff, vertex_ff) = cpu.shooter_row_with_vertices(shooter as usize, salt);
        if let (Some(vb), Some(vff)) = (self.vertex_radiosity.as_mut(), vertex_ff) {
            // dB_v = rho_v F(v <- i) dB_i, at the vertices themselves.
            for (v, (b, f)) in vb.iter_mut().zip(vff).enumerate() {
                if f > 0.0 {
                    let rho = self.vertex_reflectance[v];
                    for c in 0..3 {
                        b[c] += rho[c] * f * mean[c];
                    }
                }
            }
        }
        self.cpu_times.add(cpu.stage_name(), t.elapsed());
        let result = self.engine.shoot_with(
            &ff,
            &Shooter {
                faces: [glam::Mat4::IDENTITY; 5],
                area,
                ranks,
                resolution: self.hemicube.res,
                region: None,
            },
        )?;
        let power = self.shot_power(&[node], &result.shot_light);
        Ok((result.unshot, power))
    }

    /// Every element's radiosity, the vertex radiosity of the CPU methods,
    /// and the time per stage of all shots.
    pub fn finish(mut self) -> Result<ShotTotals> {
        let radiosity = self
            .engine
            .radiosity()?
            .into_iter()
            .map(|b| [b[0], b[1], b[2]])
            .collect();
        let mut times = self.engine.times.clone();
        times.merge(&self.cpu_times);
        Ok(ShotTotals {
            radiosity,
            vertex_radiosity: self.vertex_radiosity,
            times,
        })
    }
}

/// The coarsest hemicube resolution of `ladder` (finest first) a shot of
/// `power` may take, when the strongest shot so far carried `strongest`:
/// the finest scaled by sqrt(power / strongest), at least `floor` and a
/// quarter of the finest.
///
/// A hemicube's aliasing error in a receiver's form factor goes as 1/res,
/// so a shot adds an error of about power / res to the radiosity. Shots
/// alias independently, so their errors add in quadrature, and for a
/// given number of pixels (the render's cost) the total is least with res
/// proportional to sqrt(power) (Lagrange). The first shots, which carry
/// the direct light and most of the picture, keep the finest hemicube; the
/// hundreds of dim interreflection shots take a half or a quarter of it,
/// but never less than [`resolving_resolution`] (below it the error stops
/// being noise and turns into bias).
fn resolution_for(ladder: &[u32], power: f64, strongest: f64, floor: u32) -> u32 {
    let finest = ladder[0];
    if strongest <= 0.0 {
        return finest;
    }
    let wanted = (finest as f64 * (power / strongest).sqrt())
        .max(finest as f64 / 4.0)
        .max(floor as f64);
    ladder
        .iter()
        .copied()
        .rev()
        .find(|&res| res as f64 >= wanted)
        .unwrap_or(finest)
}

/// Pixels across a typical element the coarsest hemicube of a shot must
/// give (see [`resolving_resolution`]).
const RESOLVED_PIXELS: f64 = 1.5;

/// The hemicube resolution at which a typical element (edge h: the root
/// of the mean element area), half the scene's extent away, spans
/// [`RESOLVED_PIXELS`] pixels: `RESOLVED_PIXELS x extent / h` (a pixel at
/// the top face's centre subtends 2 / res radians, the element 2 h /
/// extent).
///
/// Below that, a receiver covers a pixel or less and its form factor is
/// mostly aliasing; the region correction's visibility (hemicube over
/// exact, clamped to 1) then turns the noise into a bias.
fn resolving_resolution(scene: &Scene, mesh: &Mesh) -> u32 {
    let area: f64 = mesh.elements.iter().map(|e| e.area as f64).sum();
    let edge = (area / mesh.elements.len().max(1) as f64).sqrt();
    if edge <= 0.0 {
        return u32::MAX;
    }
    (RESOLVED_PIXELS * scene.extent() as f64 / edge)
        .ceil()
        .min(u32::MAX as f64) as u32
}

/// A node's unshot light, from one pass over its elements.
struct UnshotLight {
    /// Mean unshot radiosity over its elements (rgb).
    mean: [f32; 3],
    /// The power that leaves it (mean channel).
    power: f64,
    /// Where it leaves from: the elements' centres weighted by their
    /// unshot power (the node's centroid when it has none).
    centre: glam::Vec3,
}

fn unshot_light(tree: &ShooterTree, mesh: &Mesh, node: u32, unshot: &[[f32; 4]]) -> UnshotLight {
    let n = &tree.nodes[node as usize];
    let mut sum = [0.0f64; 3];
    let mut weighted = glam::DVec3::ZERO;
    for &e in tree.elements(node) {
        let el = &mesh.elements[e as usize];
        let (u, a) = (unshot[e as usize], el.area as f64);
        for c in 0..3 {
            sum[c] += u[c] as f64 * a;
        }
        weighted += el.centre.as_dvec3() * ((u[0] + u[1] + u[2]) as f64 * a);
    }
    let area = n.area.max(f32::MIN_POSITIVE);
    let total = sum[0] + sum[1] + sum[2];
    UnshotLight {
        mean: sum.map(|x| (x / area as f64) as f32),
        power: total / 3.0,
        centre: if total > 0.0 {
            (weighted / total).as_vec3()
        } else {
            n.centre
        },
    }
}

/// How a region's unshot light spreads over its children: each child's
/// outline and mean unshot radiosity over the region's.
fn parts<'t>(
    tree: &'t ShooterTree,
    mesh: &Mesh,
    node: u32,
    unshot: &[[f32; 4]],
) -> Vec<(&'t [glam::Vec3], f32)> {
    let level = |m: u32| -> f64 {
        let node = &tree.nodes[m as usize];
        let power: f64 = tree
            .elements(m)
            .iter()
            .map(|&e| {
                let u = unshot[e as usize];
                (u[0] + u[1] + u[2]) as f64 * mesh.elements[e as usize].area as f64
            })
            .sum();
        power / (node.area as f64).max(f64::MIN_POSITIVE)
    };
    let n = &tree.nodes[node as usize];
    let region_level = level(node).max(f64::MIN_POSITIVE);
    n.children
        .iter()
        .map(|&c| {
            let child = &tree.nodes[c as usize];
            (child.polygon.as_slice(), (level(c) / region_level) as f32)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::{resolution_for, resolving_resolution};

    #[test]
    fn a_shot_takes_a_resolution_growing_with_the_root_of_its_power() {
        let ladder = [256, 128, 64, 32];
        // The strongest shot and those near it: the finest.
        assert_eq!(resolution_for(&ladder, 1.0, 1.0, 0), 256);
        assert_eq!(resolution_for(&ladder, 0.3, 1.0, 0), 256);
        // A quarter of the power: half the resolution; a sixteenth: a quarter.
        assert_eq!(resolution_for(&ladder, 0.25, 1.0, 0), 128);
        assert_eq!(resolution_for(&ladder, 1.0 / 16.0, 1.0, 0), 64);
        // Never below a quarter of the finest, however dim.
        assert_eq!(resolution_for(&ladder, 1e-9, 1.0, 0), 64);
        // Nor below the floor (rounded up to a rung); a floor above the
        // finest, or no shot yet: the finest.
        assert_eq!(resolution_for(&ladder, 1e-9, 1.0, 104), 128);
        assert_eq!(resolution_for(&ladder, 1e-9, 1.0, u32::MAX), 256);
        assert_eq!(resolution_for(&ladder, 1.0, 0.0, 0), 256);
        // A ladder without the rung wanted takes the next finer one.
        assert_eq!(resolution_for(&[96, 48], 1e-3, 1.0, 0), 48);
        assert_eq!(resolution_for(&[50], 1e-3, 1.0, 0), 50);
    }

    #[test]
    fn the_resolving_resolution_grows_with_the_mesh() {
        let scene = crate::scene::load_builtin("cornell").unwrap().unwrap();
        let res = |edges: f32| {
            let mesh = crate::mesh::uniform(&scene, scene.extent() / edges);
            resolving_resolution(&scene, &mesh)
        };
        // Twice the elements per edge, about twice the resolution.
        let (coarse, fine) = (res(26.0), res(52.0));
        assert!((40..=64).contains(&coarse), "{coarse}");
        assert!(
            (1.8..=2.2).contains(&(fine as f64 / coarse as f64)),
            "{fine} vs {coarse}"
        );
    }
}
