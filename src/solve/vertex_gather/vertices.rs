//! The gather at a mesh's vertices: the vertices at one place on patches
//! that meet below the crease angle are gathered once (one smooth group,
//! one value), places gathered before are taken from the cache (a refined
//! display mesh gathers only its new vertices), and, when the image says
//! which elements it shows, only their corners.

use std::collections::HashMap;

use super::{exposure, FinalGather, Frame, Meter};
use crate::formfactor::receivers::vertex_frames;
use crate::mesh::smooth::{place_cells, smooth_groups, CREASE_DEGREES};
use crate::mesh::Mesh;

/// Gathered values kept by place, so that a refined display mesh gathers
/// only its new vertices.
#[derive(Default)]
pub struct VertexCache {
    values: HashMap<(u32, [i64; 3]), [f32; 3]>,
}

impl FinalGather<'_> {
    /// Radiosity at every vertex of `display` (any mesh of the same scene;
    /// vertices no element uses get 0). Vertices at one place on patches
    /// that meet below the crease angle are gathered once and show one
    /// value. Places found in `cache` are not gathered again; new ones are
    /// added to it.
    pub fn at_vertices(&self, display: &Mesh, cache: &mut VertexCache) -> Vec<[f32; 3]> {
        self.at_vertices_metered(display, cache, &mut Meter::unwatched())
            .expect("an unwatched meter never stops")
    }

    /// [`FinalGather::at_vertices`], counting its points on `meter`; `None`
    /// when it stops them (the cache keeps what was gathered).
    pub fn at_vertices_metered(
        &self,
        display: &Mesh,
        cache: &mut VertexCache,
        meter: &mut Meter,
    ) -> Option<Vec<[f32; 3]>> {
        self.at_shown_vertices_metered(display, None, cache, meter)
    }

    /// [`FinalGather::at_vertices_metered`] at the corners of the elements
    /// `shown` marks only (`None`: all); every other vertex gets 0.
    pub fn at_shown_vertices_metered(
        &self,
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
        let vals = self.gather.at_points(&frames, None, meter)?;
        for (&g, value) in todo.iter().zip(vals) {
            cache.values.insert(key(groups.members[g].0), value);
        }
        Some(
            groups
                .group
                .iter()
                .map(|&g| match groups.members.get(g as usize) {
                    Some(&(v, _)) => cache.values.get(&key(v)).copied().unwrap_or([0.0; 3]),
                    None => [0.0; 3],
                })
                .collect(),
        )
    }
}
