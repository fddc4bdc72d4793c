//! The expert settings behind `--tune KEY=VALUE`: one table of keys, each
//! reading and writing one field of a [`Job`]. Defaults are read from
//! [`Job::default`], so they are written once.

use super::Job;
use crate::error::{Error, Result};
use crate::gather::DirectLight;
use crate::mesh::build::Mesher;
use crate::solve::{FormFactorMethod, HierarchyRule, Shooting};

/// One tuning key: its name, what it changes, and how to read and write it.
pub struct TuningKey {
    pub name: &'static str,
    pub help: &'static str,
    get: fn(&Job) -> String,
    set: fn(&mut Job, &str) -> Result<()>,
}

impl TuningKey {
    /// The key's value in `job`, as `--tune` would write it.
    pub fn value(&self, job: &Job) -> String {
        (self.get)(job)
    }
}

/// Applies `key=value` to `job`; the error names the key and what it takes.
pub fn tune(job: &mut Job, assignment: &str) -> Result<()> {
    let (key, value) = assignment.split_once('=').ok_or_else(|| {
        Error::Invalid(format!(
            "--tune takes KEY=VALUE, got {assignment:?}; `vkrad help tuning` lists the keys"
        ))
    })?;
    let (key, value) = (key.trim().replace('-', "_"), value.trim());
    let entry = TUNING.iter().find(|k| k.name == key).ok_or_else(|| {
        Error::Invalid(format!(
            "unknown tuning key {key:?}; `vkrad help tuning` lists the keys"
        ))
    })?;
    (entry.set)(job, value).map_err(|e| Error::Invalid(format!("--tune {key}={value}: {e}")))
}

/// Every tuning key, in the order `vkrad help tuning` lists them.
pub static TUNING: &[TuningKey] = &[
    TuningKey {
        name: "mesh",
        help: "mesher of the solve: uniform (quadtree) or discontinuity (shadow boundaries from every emitter vertex, thesis ch. 4)",
        get: |j| mesher_name(j.mesher).into(),
        set: |j, v| {
            let subdivide = !matches!(j.mesher, Mesher::Discontinuity { subdivide: false });
            j.mesher = parse_mesher(v, subdivide)?;
            Ok(())
        },
    },
    TuningKey {
        name: "subdivide",
        help: "with mesh=discontinuity: split its elements to the element size too (false: shadow boundaries only, the thesis's mesh)",
        get: |j| (!matches!(j.mesher, Mesher::Discontinuity { subdivide: false })).to_string(),
        set: |j, v| {
            let subdivide = parse_bool(v)?;
            if let Mesher::Discontinuity { subdivide: s } = &mut j.mesher {
                *s = subdivide;
                Ok(())
            } else if subdivide {
                Ok(())
            } else {
                Err(Error::Invalid("applies to mesh=discontinuity; give that first".into()))
            }
        },
    },
    TuningKey {
        name: "dm_res",
        help: "tile side in pixels of the discontinuity mesher's GPU visibility pass",
        get: |j| j.dm_res.to_string(),
        set: |j, v| assign(&mut j.dm_res, parse_in(v, 8, 4096)),
    },
    TuningKey {
        name: "hemicube_res",
        help: "hemicube top-face resolution in pixels (even): the finest a shot takes",
        get: |j| j.solve.hemicube_res.to_string(),
        set: |j, v| {
            let res: u32 = parse_in(v, 2, 8192)?;
            if res % 2 != 0 {
                return Err(Error::Invalid("must be even".into()));
            }
            j.solve.hemicube_res = res;
            Ok(())
        },
    },
    TuningKey {
        name: "adapt_hemicube",
        help: "each shot takes the hemicube resolution its power needs, down to a quarter (false: every shot at hemicube_res)",
        get: |j| j.solve.adapt_hemicube.to_string(),
        set: |j, v| assign(&mut j.solve.adapt_hemicube, parse_bool(v)),
    },
    TuningKey {
        name: "rays",
        help: "with --ff raytrace: rays from each receiver vertex to the shooter",
        get: |j| match j.solve.method {
            FormFactorMethod::RayTrace { rays } => rays.to_string(),
            _ => FormFactorMethod::DEFAULT_RAYS.to_string(),
        },
        set: |j, v| match &mut j.solve.method {
            FormFactorMethod::RayTrace { rays } => {
                *rays = parse_in(v, 1, 1 << 20)?;
                Ok(())
            }
            _ => Err(Error::Invalid("applies to --ff raytrace".into())),
        },
    },
    TuningKey {
        name: "stop_error",
        help: "stop shooting when the light still unshot is below this share of the radiosity shown",
        get: |j| optional(j.solve.unshot_share),
        set: |j, v| {
            j.solve.unshot_share = Some(parse_fraction(v)?);
            Ok(())
        },
    },
    TuningKey {
        name: "converge",
        help: "stop instead when the unshot power is below this fraction of the emitted power",
        get: |j| match j.solve.unshot_share {
            Some(_) => "none".into(),
            None => j.solve.converge.to_string(),
        },
        set: |j, v| {
            j.solve.converge = parse_fraction(v)?;
            j.solve.unshot_share = None;
            Ok(())
        },
    },
    TuningKey {
        name: "max_shots",
        help: "stop after this many shots at the latest",
        get: |j| j.solve.max_shots.to_string(),
        set: |j, v| assign(&mut j.solve.max_shots, parse_in(v, 1, usize::MAX)),
    },
    TuningKey {
        name: "shooting",
        help: "who shoots: hierarchical (regions whose unshot light is even) or element (one element a shot, the classic method)",
        get: |j| match j.solve.shooting {
            Shooting::Hierarchical(_) => "hierarchical".into(),
            Shooting::Element => "element".into(),
        },
        set: |j, v| {
            j.solve.shooting = match v {
                "hierarchical" => Shooting::Hierarchical(HierarchyRule::default()),
                "element" => Shooting::Element,
                _ => return Err(Error::Invalid("takes hierarchical or element".into())),
            };
            Ok(())
        },
    },
    TuningKey {
        name: "max_share",
        help: "hierarchical shooting: a region's shot carries at most this share of all the unshot power",
        get: |j| hierarchy(j).max_share.to_string(),
        set: |j, v| assign(&mut hierarchy_mut(j)?.max_share, parse_fraction(v)),
    },
    TuningKey {
        name: "uniformity",
        help: "hierarchical shooting: no element of a region more than this many times brighter or dimmer (unshot) than its mean",
        get: |j| hierarchy(j).uniformity.to_string(),
        set: |j, v| {
            let ratio: f64 = parse(v)?;
            if !(1.0..).contains(&ratio) {
                return Err(Error::Invalid("must be at least 1".into()));
            }
            hierarchy_mut(j)?.uniformity = ratio;
            Ok(())
        },
    },
    TuningKey {
        name: "in_flight",
        help: "shot batches in flight at once, 1 or 2 (auto: 2 on a GPU, 1 on a CPU device)",
        get: |j| j.solve.in_flight.map_or("auto".into(), |n| n.to_string()),
        set: |j, v| {
            j.solve.in_flight = match v {
                "auto" => None,
                _ => Some(parse_in(v, 1, 2)?),
            };
            Ok(())
        },
    },
    TuningKey {
        name: "ambient",
        help: "show the ambient term (Cohen et al. 1988) for light still unshot",
        get: |j| j.ambient.to_string(),
        set: |j, v| assign(&mut j.ambient, parse_bool(v)),
    },
    TuningKey {
        name: "check_mesh",
        help: "check every mesh (orientation, planes, area, T-junctions) before using it",
        get: |j| j.check_mesh.to_string(),
        set: |j, v| assign(&mut j.check_mesh, parse_bool(v)),
    },
    TuningKey {
        name: "final_gather",
        help: "gather every shown point's light from the solved elements with exact form factors (false: show the solver's own vertex values; on many patches the solve then needs thousands of shots)",
        get: |j| j.final_gather.is_some().to_string(),
        set: |j, v| {
            j.final_gather = match parse_bool(v)? {
                true => Some(j.final_gather.unwrap_or_default()),
                false => None,
            };
            Ok(())
        },
    },
    TuningKey {
        name: "gather_passes",
        help: "Jacobi passes of the final gather at the element centres; past four, the later bounces are added as a geometric tail",
        get: |j| gather(j).source_passes.to_string(),
        set: |j, v| assign(&mut gather_mut(j)?.source_passes, parse_in(v, 0, 1000)),
    },
    TuningKey {
        name: "reflected_reuse",
        help: "Ward's error bound for a display point taking its reflected light from the element centres instead of gathering it, from centres whose hemisphere rays agreed within 2% only (0: never)",
        get: |j| gather(j).reuse.to_string(),
        set: |j, v| {
            let reuse: f32 = parse(v)?;
            if !(0.0..).contains(&reuse) {
                return Err(Error::Invalid("must be 0 or more".into()));
            }
            gather_mut(j)?.reuse = reuse;
            Ok(())
        },
    },
    TuningKey {
        name: "hemisphere_rays",
        help: "rays a gathered point sends over its hemisphere for the reflected light, in a scene of many small patches",
        get: |j| gather(j).hemisphere_rays.to_string(),
        set: |j, v| assign(&mut gather_mut(j)?.hemisphere_rays, parse_in(v, 1, 1 << 16)),
    },
    TuningKey {
        name: "direct_light",
        help: "where the final gather traces the emitters' direct light: auto (the GPU unless the device is the CPU), cpu or gpu",
        get: |j| device_name(gather(j).direct_light).into(),
        set: |j, v| assign(&mut gather_mut(j)?.direct_light, parse_device(v)),
    },
    TuningKey {
        name: "ray_device",
        help: "where the final gather's first-hit rays (camera and hemisphere rays) are traced: auto, cpu or gpu",
        get: |j| device_name(gather(j).ray_device).into(),
        set: |j, v| assign(&mut gather_mut(j)?.ray_device, parse_device(v)),
    },
    TuningKey {
        name: "exact_lights",
        help: "lights a gathered point takes each with its own shadow rays, those that give it most first; the rest share one estimate (all: every light, as with few lights)",
        get: |j| match gather(j).exact_lights {
            usize::MAX => "all".into(),
            n => n.to_string(),
        },
        set: |j, v| {
            gather_mut(j)?.exact_lights = match v {
                "all" => usize::MAX,
                _ => parse_in(v, 1, 1 << 20)?,
            };
            Ok(())
        },
    },
    TuningKey {
        name: "display_edge",
        help: "longest element edge of the display mesh the gather shades (auto: half the default element size; with --quality draft the whole, fine 0.35 of it)",
        get: |j| optional(j.display_edge),
        set: |j, v| {
            j.display_edge = match v {
                "auto" => None,
                _ => Some(parse_positive(v)?),
            };
            Ok(())
        },
    },
    TuningKey {
        name: "display_mesh",
        help: "mesher of the display mesh: discontinuity (shadow and contact lines become edges) or uniform",
        get: |j| j.display_mesher.map_or("the solve's", mesher_name).into(),
        set: |j, v| {
            j.display_mesher = Some(parse_mesher(v, true)?);
            Ok(())
        },
    },
    TuningKey {
        name: "display_refinements",
        help: "passes that split display elements where the value gathered at their centroid is off the interpolated one",
        get: |j| j.display_refinements.to_string(),
        set: |j, v| assign(&mut j.display_refinements, parse_in(v, 0, 64)),
    },
    TuningKey {
        name: "adaptive",
        help: "a-posteriori passes (with mesh=discontinuity): split the solved elements whose centroid error is over `tolerance`, and solve again",
        get: |j| j.adaptive.to_string(),
        set: |j, v| assign(&mut j.adaptive, parse_in(v, 0, 64)),
    },
    TuningKey {
        name: "tolerance",
        help: "with adaptive: split elements whose centroid error is over this share of the lit surfaces' mean radiosity",
        get: |j| j.tolerance.to_string(),
        set: |j, v| assign(&mut j.tolerance, parse_positive(v)),
    },
    TuningKey {
        name: "max_elements",
        help: "with adaptive: stop refining before the mesh passes this many elements",
        get: |j| optional(j.max_elements),
        set: |j, v| {
            j.max_elements = match v {
                "none" => None,
                _ => Some(parse_in(v, 1, usize::MAX)?),
            };
            Ok(())
        },
    },
];

/// Stores `value` in `field` when it parsed.
fn assign<T>(field: &mut T, value: Result<T>) -> Result<()> {
    *field = value?;
    Ok(())
}

fn optional<T: ToString>(value: Option<T>) -> String {
    value.map_or("none".into(), |v| v.to_string())
}

fn hierarchy(job: &Job) -> HierarchyRule {
    match job.solve.shooting {
        Shooting::Hierarchical(rule) => rule,
        Shooting::Element => HierarchyRule::default(),
    }
}

fn hierarchy_mut(job: &mut Job) -> Result<&mut HierarchyRule> {
    match &mut job.solve.shooting {
        Shooting::Hierarchical(rule) => Ok(rule),
        Shooting::Element => Err(Error::Invalid("applies to shooting=hierarchical".into())),
    }
}

fn gather(job: &Job) -> crate::gather::VertexGather {
    job.final_gather.unwrap_or_default()
}

fn gather_mut(job: &mut Job) -> Result<&mut crate::gather::VertexGather> {
    job.final_gather
        .as_mut()
        .ok_or_else(|| Error::Invalid("applies only with final_gather=true".into()))
}

fn mesher_name(mesher: Mesher) -> &'static str {
    match mesher {
        Mesher::Uniform => "uniform",
        Mesher::Discontinuity { .. } => "discontinuity",
    }
}

fn parse_mesher(v: &str, subdivide: bool) -> Result<Mesher> {
    match v {
        "uniform" => Ok(Mesher::Uniform),
        "discontinuity" => Ok(Mesher::Discontinuity { subdivide }),
        _ => Err(Error::Invalid("takes uniform or discontinuity".into())),
    }
}

fn device_name(d: DirectLight) -> &'static str {
    match d {
        DirectLight::Auto => "auto",
        DirectLight::Cpu => "cpu",
        DirectLight::Gpu => "gpu",
    }
}

fn parse_device(v: &str) -> Result<DirectLight> {
    match v {
        "auto" => Ok(DirectLight::Auto),
        "cpu" => Ok(DirectLight::Cpu),
        "gpu" => Ok(DirectLight::Gpu),
        _ => Err(Error::Invalid("takes auto, cpu or gpu".into())),
    }
}

fn parse<T: std::str::FromStr>(v: &str) -> Result<T> {
    v.parse()
        .map_err(|_| Error::Invalid(format!("{v:?} is not a number of the right kind")))
}

fn parse_bool(v: &str) -> Result<bool> {
    match v {
        "true" | "on" | "yes" | "1" => Ok(true),
        "false" | "off" | "no" | "0" => Ok(false),
        _ => Err(Error::Invalid("takes true or false".into())),
    }
}

fn parse_in<T: std::str::FromStr + PartialOrd + std::fmt::Display>(
    v: &str,
    lo: T,
    hi: T,
) -> Result<T> {
    let x: T = parse(v)?;
    if x < lo || x > hi {
        return Err(Error::Invalid(format!("must be from {lo} to {hi}")));
    }
    Ok(x)
}

fn parse_fraction(v: &str) -> Result<f64> {
    let f: f64 = parse(v)?;
    if !(f > 0.0 && f < 1.0) {
        return Err(Error::Invalid("takes a fraction between 0 and 1".into()));
    }
    Ok(f)
}

fn parse_positive(v: &str) -> Result<f32> {
    let x: f32 = parse(v)?;
    if !(x > 0.0 && x.is_finite()) {
        return Err(Error::Invalid("must be a positive number".into()));
    }
    Ok(x)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_key_reads_back_what_it_was_given_its_own_default() {
        for key in TUNING {
            let mut job = Job::default();
            // A key that applies under another setting is read under it.
            if key.name == "rays" {
                job.solve.method = FormFactorMethod::RayTrace {
                    rays: FormFactorMethod::DEFAULT_RAYS,
                };
            }
            let default = key.value(&job);
            if default == "none" || default == "the solve's" {
                continue;
            }
            tune(&mut job, &format!("{}={default}", key.name))
                .unwrap_or_else(|e| panic!("{}: its default {default:?} refused: {e}", key.name));
            assert_eq!(key.value(&job), default, "{}", key.name);
        }
    }

    #[test]
    fn a_bad_key_or_value_is_refused_with_its_name() {
        let mut job = Job::default();
        let err = tune(&mut job, "hemicube_res=7").unwrap_err().to_string();
        assert!(
            err.contains("hemicube_res") && err.contains("even"),
            "{err}"
        );
        let err = tune(&mut job, "no_such=1").unwrap_err().to_string();
        assert!(err.contains("help tuning"), "{err}");
        let err = tune(&mut job, "gather_passes").unwrap_err().to_string();
        assert!(err.contains("KEY=VALUE"), "{err}");
        tune(&mut job, "gather-passes=3").unwrap();
        assert_eq!(job.final_gather.unwrap().source_passes, 3);
    }
}
