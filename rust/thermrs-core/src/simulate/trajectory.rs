//! A cycle's joint-space trajectory: to each camera's pose in turn (every joint at the run's
//! share of its maximum rate), a dwell there, then away to the rest pose; and the joint
//! positions along it.

use rand::rngs::StdRng;
use rand_distr::{Distribution, StandardNormal};

use crate::model::pose_joints_rad;
use crate::rig::Rig;
use crate::scenario::Scenario;

/// One piece of a cycle's joint-space trajectory: a move (`dwell` None) or a dwell at a
/// camera's pose.
pub(super) struct Segment {
    pub(super) t0: f64,
    pub(super) t1: f64,
    pub(super) q0: [f64; 6],
    pub(super) q1: [f64; 6],
    pub(super) dwell: Option<usize>,
}

impl Segment {
    /// A move from `from` to `to` starting at `t0`, every joint at `speed` × its maximum rate
    /// (°/s); it lasts as long as the slowest joint needs.
    fn movement(
        t0: f64,
        from: [f64; 6],
        to: [f64; 6],
        max_rate_deg_s: &[f64; 6],
        speed: f64,
    ) -> Segment {
        let dur = (0..6)
            .map(|j| (to[j] - from[j]).abs() / (max_rate_deg_s[j].to_radians() * speed))
            .fold(0.0, f64::max);
        Segment {
            t0,
            t1: t0 + dur,
            q0: from,
            q1: to,
            dwell: None,
        }
    }
}

/// The segments of one cycle starting at `cycle_t` (s) from `q_cur` (the last position, `None`
/// before the first move): per camera a move to its pose (with per-visit repeatability noise
/// drawn from `rng`, joint by joint) and a dwell there, then away to rest facing the thermal
/// camera. Updates `q_cur`.
pub(super) fn plan_cycle(
    rig: &Rig,
    sc: &Scenario,
    cycle_t: f64,
    speed: f64,
    q_cur: &mut Option<[f64; 6]>,
    rng: &mut StdRng,
) -> Vec<Segment> {
    let mut segs: Vec<Segment> = Vec::new();
    let mut t = cycle_t;
    let mut move_to = |t: &mut f64, target: [f64; 6], segs: &mut Vec<Segment>| {
        let mv = Segment::movement(
            *t,
            q_cur.unwrap_or(target),
            target,
            &sc.motion.max_rate_deg_s,
            speed,
        );
        *t = mv.t1;
        segs.push(mv);
        *q_cur = Some(target);
    };
    for (ci, c) in rig.camera.iter().enumerate() {
        let pose = rig.pose_by_name(&c.pose).expect("validated");
        let mut target = pose_joints_rad(&pose.joints_deg);
        for v in target.iter_mut() {
            let z: f64 = StandardNormal.sample(rng);
            *v += sc.motion.repeatability_urad * 1e-6 * z;
        }
        move_to(&mut t, target, &mut segs);
        segs.push(Segment {
            t0: t,
            t1: t + sc.motion.dwell_s,
            q0: target,
            q1: target,
            dwell: Some(ci),
        });
        t += sc.motion.dwell_s;
    }
    // Then away from the cameras, to rest facing the thermal camera.
    let first = rig.pose_by_name(&rig.camera[0].pose).expect("validated");
    let mut rest = pose_joints_rad(&first.joints_deg);
    for (j, v) in rest.iter_mut().enumerate() {
        *v += sc.motion.rest_offset_deg[j].to_radians();
    }
    move_to(&mut t, rest, &mut segs);
    segs
}

/// When the cycle's moves and dwells end (s).
pub(super) fn end_of(segs: &[Segment]) -> f64 {
    segs.last().map(|s| s.t1).unwrap_or(f64::NEG_INFINITY)
}

/// The joint positions at time `t` (s): linear within a segment, held outside.
pub(super) fn q_at(segs: &[Segment], t: f64) -> [f64; 6] {
    for sgm in segs {
        if t < sgm.t1 || sgm.t1 <= sgm.t0 && t <= sgm.t1 {
            if t <= sgm.t0 {
                return sgm.q0;
            }
            let f = ((t - sgm.t0) / (sgm.t1 - sgm.t0)).clamp(0.0, 1.0);
            return std::array::from_fn(|j| sgm.q0[j] + f * (sgm.q1[j] - sgm.q0[j]));
        }
    }
    segs.last().map(|sg| sg.q1).unwrap_or([0.0; 6])
}

/// Whether the spot moves during an exposure from `t` for `exposure_s`.
pub(super) fn moving(segs: &[Segment], t: f64, exposure_s: f64) -> bool {
    segs.iter()
        .any(|sg| sg.dwell.is_none() && sg.t1 > sg.t0 && t < sg.t1 && t + exposure_s > sg.t0)
}

/// The joint-state times of a cycle: a regular grid at the scenario's joint rate plus every
/// segment boundary, sorted, near-duplicates dropped.
pub(super) fn joint_times(segs: &[Segment], sc: &Scenario, cycle_t: f64, cycle_s: f64) -> Vec<f64> {
    let mut tj: Vec<f64> = segs.iter().flat_map(|sg| [sg.t0, sg.t1]).collect();
    let step = 1.0 / sc.motion.joint_rate_hz;
    let mut k = 0.0;
    while cycle_t + k * step < cycle_t + cycle_s {
        tj.push(cycle_t + k * step);
        k += 1.0;
    }
    tj.sort_by(f64::total_cmp);
    tj.dedup_by(|a, b| (*a - *b).abs() < 1e-9);
    tj
}
