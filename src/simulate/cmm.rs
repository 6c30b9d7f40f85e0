//! The CMM side of a machining test: the finished piece placed on the CMM
//! (a seeded rigid placement: any rotation, any offset, or the part frame
//! aligned on W as the plan's DMIS program asks), the CMM's noise along
//! each probing direction, and the nine-section heights a micrometer reads.

use std::collections::BTreeMap;

use nalgebra::{Isometry3, Point3, UnitQuaternion, Vector3};
use rand::{Rng, RngExt};
use rand_distr::{Distribution, Normal};

use crate::formats::heights::SectionHeight;
use crate::formats::points::PlanPoint;

/// Where the piece lies on the CMM.
#[derive(Clone, Debug, PartialEq)]
pub enum Placement {
    /// Seeded: a uniformly random rotation and an offset anywhere within
    /// 500 mm of the CMM's origin, as when a piece is put down by hand and
    /// measured in machine coordinates.
    Random,
    /// The CMM's part frame aligned on W (what the plan's DMIS program asks
    /// the operator to set up): the identity.
    Aligned,
    /// A given rigid transform from W to the CMM frame.
    Given(Isometry3<f64>),
}

impl Placement {
    /// The transform from W to the CMM frame.
    pub fn draw<R: Rng + ?Sized>(&self, rng: &mut R) -> Isometry3<f64> {
        match self {
            Placement::Random => {
                // Uniform rotation: a normalized Gaussian quaternion.
                let g = Normal::new(0.0, 1.0).unwrap();
                let q = nalgebra::Quaternion::new(
                    g.sample(rng),
                    g.sample(rng),
                    g.sample(rng),
                    g.sample(rng),
                );
                let r = UnitQuaternion::from_quaternion(q);
                let t = Vector3::new(
                    rng.random_range(-500.0..500.0),
                    rng.random_range(-500.0..500.0),
                    rng.random_range(-500.0..500.0),
                );
                Isometry3::from_parts(t.into(), r)
            }
            Placement::Aligned => Isometry3::identity(),
            Placement::Given(iso) => *iso,
        }
    }
}

/// One Gaussian draw of standard deviation `sigma_um`, in mm (zero without
/// drawing when the deviation is zero, so a noiseless run consumes no
/// random numbers).
pub(crate) fn noise_mm<R: Rng + ?Sized>(sigma_um: f64, rng: &mut R) -> f64 {
    if sigma_um > 0.0 {
        Normal::new(0.0, sigma_um * 1e-3).unwrap().sample(rng)
    } else {
        0.0
    }
}

/// Applies a placement to points of W.
pub fn place(iso: &Isometry3<f64>, p: &Vector3<f64>) -> Vector3<f64> {
    (iso * Point3::from(*p)).coords
}

/// The nine-section heights from the measured points in W: each point's
/// deviation along its nominal normal, averaged per section (the plan's
/// poses in execution order), relative to section 1, in um.
pub fn heights(points: &[PlanPoint], measured_w: &[Vector3<f64>]) -> Vec<SectionHeight> {
    let mut sums: BTreeMap<u32, (f64, usize)> = BTreeMap::new();
    for (p, m) in points.iter().zip(measured_w) {
        let e = sums.entry(p.seq).or_insert((0.0, 0));
        e.0 += p.n.dot(&(m - p.p)) * 1e3;
        e.1 += 1;
    }
    let means: Vec<f64> = sums.values().map(|(s, k)| s / *k as f64).collect();
    let reference = means.first().copied().unwrap_or(0.0);
    means
        .iter()
        .enumerate()
        .map(|(i, m)| SectionHeight {
            section: i as u32 + 1,
            height_um: if i == 0 { 0.0 } else { m - reference },
            line: 0,
        })
        .collect()
}
