//! The gather at a mesh's vertices: the vertices at one place on patches
//! that meet below the crease angle are gathered once (one smooth group,
//! one value), places gathered before are taken from the cache (a refined
//! display mesh gathers only its new vertices), and, when the image says
//! which elements it shows, only their corners.

use std::collections::HashMap;

use glam::Vec3;
use rayon::prelude::*;

use super::facets::FacetTurn;
use super::hemisphere_rays::ReflectedTurn;
use super::point_gather::Linking;
use super::shared_reflected::{Sample, Sharing, FIRST_SHARE};
use super::Gathered;
use super::{exposure, FinalGather, Frame, Meter};
use crate::formfactor::receivers::{vertex_frames, VERTEX_INSET};
use crate::mesh::smooth::{place_cells, smooth_groups, CREASE_DEGREES, FLAT_COSINE};
use crate::mesh::Mesh;
use crate::output::tonemap::luminance;
use crate::scene::Scene;

/// Gathered values kept by place, so that a refined display mesh gathers
/// only its new vertices.
#[derive(Default)]
pub struct VertexCache {
    values: HashMap<(u32, [i64; 3]), [f32; 3]>,
    /// The emitters' direct light in each value gathered at a vertex
    /// (before its reflectance), and how its reflected light turns with
    /// the normal, for its facets ([`FacetTurn`], [`ReflectedTurn`]).
    facing: HashMap<(u32, [i64; 3]), Facing>,
}

/// What a gathered value needs to be turned to a facet's normal.
#[derive(Debug, Clone, Copy, Default)]
struct Facing {
    direct: Vec3,
    turn: ReflectedTurn,
}

impl VertexCache {
    /// Keeps each value, gathered at its point on its patch, for a
    /// vertex there.
    pub fn remember(
        &mut self,
        scene: &Scene,
        gathered: impl Iterator<Item = (u32, Vec3, [f32; 3])>,
    ) {
        let place = place_cells(scene);
        for (patch, point, value) in gathered {
            self.values.insert((patch, place(point)), value);
        }
    }
}

impl FinalGather<'_> {
    /// Radiosity at every vertex of `display` (any mesh of the same scene;
    /// vertices no element uses get 0). Vertices at one place on patches
    /// that meet below the crease angle are gathered once and show one
    /// value. Places found in `cache` are not gathered again; new ones are
    /// added to it.
    pub fn at_vertices(&mut self, display: &Mesh, cache: &mut VertexCache) -> Vec<[f32; 3]> {
        self.at_vertices_metered(display, cache, &mut Meter::unwatched())
            .expect("an unwatched meter never stops")
    }

    /// [`FinalGather::at_vertices`], counting its points on `meter`; `None`
    /// when it stops them (the cache keeps what was gathered).
    pub fn at_vertices_metered(
        &mut self,
        display: &Mesh,
        cache: &mut VertexCache,
        meter: &mut Meter,
    ) -> Option<Vec<[f32; 3]>> {
        self.at_shown_vertices_metered(display, None, cache, meter)
    }

    /// [`FinalGather::at_vertices_metered`] at the corners of the elements
    /// `shown` marks only (`None`: all); every other vertex gets 0.
    pub fn at_shown_vertices_metered(
        &mut self,
        display: &Mesh,
        shown: Option<&[bool]>,
        cache: &mut VertexCache,
        meter: &mut Meter,
    ) -> Option<Vec<[f32; 3]>> {
        let scene = self.gather.scene;
        let (points, _, patches) = vertex_frames(scene, display);
        let groups = smooth_groups(scene, display, CREASE_DEGREES);
        let place = place_cells(scene);
        let key = |v: u32| (patches[v as usize], place(display.vertices[v as usize]));
        // The groups some shown element has a corner in.
        let wanted = shown.map(|shown| {
            let mut wanted = vec![false; groups.members.len()];
            for (e, _) in display.elements.iter().zip(shown).filter(|(_, &s)| s) {
                for &v in e.corners() {
                    if let Some(w) = wanted.get_mut(groups.group[v as usize] as usize) {
                        *w = true;
                    }
                }
            }
            wanted
        });
        let todo: Vec<usize> = (0..groups.members.len())
            .filter(|&g| wanted.as_ref().is_none_or(|w| w[g]))
            .filter(|&g| !cache.values.contains_key(&key(groups.members[g].0)))
            .collect();
        let mut frames: Vec<Frame> = todo
            .iter()
            .map(|&g| {
                let (v, normal) = groups.members[g];
                (points[v as usize], normal, patches[v as usize])
            })
            .collect();
        let vertices: Vec<u32> = todo.iter().map(|&g| groups.members[g].0).collect();
        exposure::unenclosed(
            scene,
            &self.gather.occluders,
            display,
            &vertices,
            &mut frames,
        );
        // What the groups leave out of the count (the meter was told of
        // every vertex).
        meter.total = meter
            .total
            .saturating_sub(display.vertices.len() - frames.len());
        let vals = self.at_display_points(&frames, meter)?;
        for (&g, light) in todo.iter().zip(vals) {
            let at = key(groups.members[g].0);
            cache.values.insert(at, light.value);
            cache.facing.insert(at, light.facing);
        }
        // Each vertex its group's value, the direct light turned to its
        // own facet.
        Some(
            (0..display.vertices.len())
                .into_par_iter()
                .map(|v| {
                    let Some(&(m, normal)) = groups.members.get(groups.group[v] as usize) else {
                        return [0.0; 3];
                    };
                    let at = key(m);
                    let Some(&value) = cache.values.get(&at) else {
                        return [0.0; 3];
                    };
                    match cache.facing.get(&at) {
                        Some(facing) => {
                            self.on_facet(value, facing, display.vertices[v], normal, patches[v])
                        }
                        None => value,
                    }
                })
                .collect(),
        )
    }
}

impl FinalGather<'_> {
    /// Radiosity at points on display elements (each with its normal and
    /// the elements of one patch it lies on, such as an edge's midpoint before a split makes it a
    /// vertex), gathered as a vertex there would be: moved a hair toward
    /// its patch's centre, or into its element where that is enclosed,
    /// its hemisphere rays pooled with its neighbours'. (A point on a
    /// contact line gathered where it lies reads about half the light of
    /// the vertex it becomes.) Its direct light is turned to the first
    /// element's own facet ([`FacetTurn`]), as that element's corners
    /// are. Counted on `meter`, whose total the caller has given them.
    pub fn at_element_points_metered(
        &mut self,
        display: &Mesh,
        points: &[(Vec3, Vec3, Vec<u32>)],
        meter: &mut Meter,
    ) -> Option<Vec<Probed>> {
        let scene = self.gather.scene;
        let mut frames: Vec<Frame> = points
            .iter()
            .map(|(p, normal, around)| {
                let patch = display.elements[around[0] as usize].patch;
                let towards = scene.patches[patch as usize].centroid();
                (*p + VERTEX_INSET * (towards - *p), *normal, patch)
            })
            .collect();
        let corners: Vec<Vec3> = points.iter().map(|&(p, _, _)| p).collect();
        let around = |i: usize| points[i].2.clone();
        exposure::unenclosed_points(
            scene,
            &self.gather.occluders,
            display,
            &corners,
            &around,
            &mut frames,
        );
        let gathered = self.at_display_points(&frames, meter)?;
        Some(
            gathered
                .into_iter()
                .zip(points)
                .map(|(light, (p, normal, around))| {
                    let patch = display.elements[around[0] as usize].patch;
                    Probed {
                        value: self.on_facet(light.value, &light.facing, *p, *normal, patch),
                        noise: light.noise,
                    }
                })
                .collect(),
        )
    }

    /// `value`, gathered at `p` with `normal`, as a corner of a facet of
    /// `patch` shows it: its direct light turned to the facet's own normal
    /// ([`FacetTurn`]), and its reflected light by how it turns with the
    /// normal ([`ReflectedTurn`]), where the facet's is not `normal`.
    fn on_facet(
        &self,
        value: [f32; 3],
        facing: &Facing,
        p: Vec3,
        normal: Vec3,
        patch: u32,
    ) -> [f32; 3] {
        let scene = self.gather.scene;
        let facet = scene.patches[patch as usize].normal;
        if facet.dot(normal) >= FLAT_COSINE {
            return value;
        }
        let turn = self.facet_turn.get_or_init(|| FacetTurn::new(scene));
        let gain = turn.gain(p, normal, facet);
        let received = facing.direct * (gain - 1.0) + facing.turn.change(facet - normal);
        let change = self.rho_of(patch) * received;
        (Vec3::from(value) + change).max(Vec3::ZERO).to_array()
    }

    /// Radiosity at display points `frames`. In a scene whose reflected
    /// light hemisphere rays gather, the points pool those rays with
    /// their neighbours' ([`shared_reflected`](super::shared_reflected)):
    /// each sends a share of them, and only those the pool leaves short
    /// send them all.
    fn at_display_points(
        &mut self,
        frames: &[Frame],
        meter: &mut Meter,
    ) -> Option<Vec<DisplayLight>> {
        let rays = self.gather.hemisphere_rays.rays;
        if !self.gather.hemisphere_rays.any() || rays < FIRST_SHARE {
            let gathered =
                (self.gather).gather_points(frames, None, None, Linking::None, None, meter)?;
            return Some(
                gathered
                    .into_iter()
                    .zip(frames)
                    .map(|((b, g), frame)| DisplayLight {
                        value: b.to_array(),
                        facing: Facing {
                            direct: g.direct,
                            turn: g.reflected_turn,
                        },
                        noise: self.reflectance_level(frame.2) * g.reflected_error,
                    })
                    .collect(),
            );
        }
        // Every point with a share of the rays, measuring how far its
        // light holds. The pool takes their noise down, so none sends
        // more rays where its share alone is noisy; those the pool leaves
        // short do, when they gather again below. (Boosting every share
        // took CornellBox-Sphere's lit-mesh gather from 5.6 to 14.1 s
        // for the same error.)
        self.gather.hemisphere_rays.set_rays(rays / FIRST_SHARE);
        let noise = std::mem::replace(&mut self.gather.settings.ray_noise, f32::INFINITY);
        let first =
            (self.gather).gather_points(frames, None, Some(true), Linking::None, None, meter);
        self.gather.settings.ray_noise = noise;
        self.gather.hemisphere_rays.set_rays(rays);
        let first: Vec<(Vec3, Gathered)> = first?;
        // What each sample's reflected light stands on: its standard
        // error and its rays.
        let mut errors: Vec<f32> = first.iter().map(|(_, g)| g.reflected_error).collect();
        let mut turns: Vec<ReflectedTurn> = first.iter().map(|(_, g)| g.reflected_turn).collect();
        let scene = self.gather.scene;
        let surface = self.surfaces.get_or_init(|| scene.smooth_surfaces());
        let mut samples: Vec<Sample> = frames
            .iter()
            .zip(&first)
            .map(|(&(point, normal, patch), (_, g))| Sample {
                point,
                normal,
                surface: surface.get(patch as usize).copied().unwrap_or(u32::MAX),
                reflected: g.reflected,
                reach: g.reach(),
                // No reach: the light came from the reflected cache, or
                // every ray left the scene; either needs no more rays.
                rays: match g.reach().is_finite() {
                    true => (rays / FIRST_SHARE) as f32,
                    false => rays as f32,
                },
            })
            .collect();
        let sharing = Sharing::new(&samples);
        let short: Vec<usize> = (0..samples.len())
            .into_par_iter()
            .filter(|&i| sharing.effective_rays(i, &samples) < rays as f32)
            .collect();
        self.pooled[0] += samples.len();
        self.pooled[1] += short.len();
        // The short ones gather their reflected light again with every
        // ray (their direct light is known).
        let again: Vec<Frame> = short.iter().map(|&i| frames[i]).collect();
        let direct: Vec<Vec3> = short.iter().map(|&i| first[i].1.direct).collect();
        meter.total += again.len();
        let regathered =
            self.gather
                .gather_points(&again, None, None, Linking::None, Some(&direct), meter)?;
        for (&i, (_, g)) in short.iter().zip(regathered) {
            samples[i].reflected = g.reflected;
            samples[i].rays = rays as f32;
            errors[i] = g.reflected_error;
            turns[i] = g.reflected_turn;
        }
        // Each first radiosity with its first reflected light swapped
        // for the pool's, whose error is its own over the root of the
        // rays the pool adds.
        let pooled = sharing.pooled(&samples);
        Some(
            (first.iter().zip(frames).zip(pooled).enumerate())
                .map(|(i, (((b, g), frame), pooled))| {
                    let b = *b + self.rho_of(frame.2) * (pooled.reflected - g.reflected);
                    let effective = pooled.rays.max(samples[i].rays);
                    let error = errors[i] * (samples[i].rays / effective.max(1.0)).sqrt();
                    DisplayLight {
                        value: b.to_array(),
                        facing: Facing {
                            direct: g.direct,
                            turn: turns[i],
                        },
                        noise: self.reflectance_level(frame.2) * error,
                    }
                })
                .collect(),
        )
    }

    /// Display points that pooled their hemisphere rays with their
    /// neighbours', and how many of them sent all their rays after all.
    pub fn pooled_rays(&self) -> (usize, usize) {
        (self.pooled[0], self.pooled[1])
    }

    /// A display point's reflectance: its patch's mean.
    fn rho_of(&self, patch: u32) -> Vec3 {
        self.gather
            .patch_rho
            .get(patch as usize)
            .copied()
            .unwrap_or_default()
    }

    /// ... its luminance, which scales the noise of the light it receives
    /// to that of the light it reflects.
    pub(super) fn reflectance_level(&self, patch: u32) -> f32 {
        luminance(self.rho_of(patch).to_array())
    }
}

/// A display point's gathered light.
struct DisplayLight {
    value: [f32; 3],
    /// The emitters' direct light in it, before its reflectance, and how
    /// its reflected light turns.
    facing: Facing,
    /// The standard error of the luminance of `value`, from the spread of
    /// its hemisphere rays (0 where none gathered it).
    noise: f32,
}

/// The light gathered at a point a refinement pass probes.
#[derive(Debug, Clone, Copy, Default)]
pub struct Probed {
    pub value: [f32; 3],
    /// The standard error of its luminance, from the spread of its
    /// hemisphere rays (0 where none gathered it: the exact form factors
    /// and the emitters' stratified rays are taken as exact).
    pub noise: f32,
}

impl Probed {
    /// The standard error of this point's gap from the mean of `corners`
    /// mesh values, those taken as noisy as the point.
    pub fn gap_error(&self, corners: usize) -> f32 {
        self.noise * (1.0 + 1.0 / corners as f32).sqrt()
    }
}
