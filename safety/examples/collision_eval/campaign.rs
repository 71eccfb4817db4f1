//! Contact campaigns: contacts during free motion, with detection delay, misses, isolation and
//! false alarms per variant.

use dynamics::{Data, lwr4, point_jacobian};
use nalgebra::Vector3;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use safety::{CollisionDetector, Detection, MomentumObserver};

use crate::scenario::{random_contact_geometry, random_waypoints, to_base};
use crate::support::{Contact, Profile, Quintic, Trajectory};
use crate::variant::Variant;
use crate::world::World;
use crate::{T, THRESHOLD};

/// Contact durations of the 50 N campaigns on links 4–7: (duration [s], tag).
pub const FIFTY_NEWTON: [(f64, &str); 2] = [(0.02, "20 ms"), (0.01, "10 ms")];

/// The 50 N half-sine campaign on links 4–7 with contacts of `duration_s`, `n` contacts.
pub fn fifty_newton_campaign(
    seed: u64,
    n: usize,
    duration_s: f64,
    variants: &[Variant],
) -> Vec<Campaign> {
    campaign(
        seed + (duration_s * 1e3) as u64,
        n,
        &[3, 4, 5, 6],
        ForceSpec::Fixed(50.0),
        duration_s,
        variants,
    )
}

#[derive(Clone, Copy)]
pub enum ForceSpec {
    Fixed(f64),
    Uniform(f64, f64),
}

#[derive(Clone)]
pub struct ContactRecord {
    pub link: usize,
    pub force_n: f64,
    pub start: f64,
    /// Peak |τ_ext| on the hit link's own joint [Nm] (static J_vᵀF at the contact start):
    /// below the isolation level the contact is indistinguishable from one on the previous link.
    pub own_joint_torque: f64,
    /// First tick at which some unfiltered |τ_ext,j| exceeds 6 Nm, after the start [s]: the
    /// delay of an ideal detector.
    pub ideal_delay_s: Option<f64>,
    pub delay_s: Option<f64>,
    pub onset_link: Option<usize>,
    pub episode_link: Option<usize>,
    /// Index range of the detection window in `series`.
    pub window: (usize, usize),
}

pub struct Campaign {
    pub label: String,
    pub records: Vec<ContactRecord>,
    pub series: Vec<f32>,
    pub false_alarms: usize,
    /// Onsets after a contact's window but within 1.2 s of its start (rebound of the arm).
    pub retriggers: usize,
    pub free_hours: f64,
}

/// A planned contact campaign: the motion, its contacts and their records (truth).
pub struct ContactPlan {
    pub q0: crate::support::V7,
    pub trajectory: Quintic,
    pub contacts: Vec<Contact>,
    pub records: Vec<ContactRecord>,
    /// Simulated length [s].
    pub total_s: f64,
}

/// `n` contacts during free motion, one every ≈1.5 s, on random `links`. The force opposes the
/// contact point's motion (the arm runs into something), tilted randomly; at low point speed it
/// pushes into the surface. With `leading_side`, a point whose surface would be pulled by that
/// force is moved to the opposite side of the link (the side that runs into the obstacle), so
/// every force pushes into the surface as a rigid obstacle's does; without, the point stays
/// where it was drawn (the uncalibrated campaigns, kept comparable with earlier runs).
pub fn plan_contacts(
    seed: u64,
    n: usize,
    links: &[usize],
    force: ForceSpec,
    duration_s: f64,
    leading_side: bool,
) -> ContactPlan {
    let mut rng = StdRng::seed_from_u64(seed);
    let spacing = 1.5;
    let mut waypoints = random_waypoints(&mut rng, 1);
    let q0 = waypoints[0];
    waypoints.extend(random_waypoints(
        &mut rng,
        (n as f64 * spacing / 2.0) as usize + 10,
    ));
    let trajectory = Quintic::new(&waypoints, 0.7, 0.5, 0.5);
    let nominal = lwr4();
    let mut data = Data::new(&nominal);
    let mut contacts = Vec::new();
    let mut records = Vec::new();
    for i in 0..n {
        let start = 1.0 + spacing * i as f64 + rng.random_range(0.0..0.3);
        let link = links[rng.random_range(0..links.len())];
        let (mut point, direction_in_link) = random_contact_geometry(&mut rng, link);
        let (q_at, qd_at, _) = trajectory.sample(start);
        let magnitude = match force {
            ForceSpec::Fixed(f) => f,
            ForceSpec::Uniform(a, b) => rng.random_range(a..b),
        };
        let jacobian = point_jacobian(&nominal, &mut data, &q_at, link, &point);
        let jv = jacobian.fixed_rows::<3>(0).into_owned();
        let point_velocity = jv * qd_at;
        let tilt = Vector3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        ) * 0.5;
        let direction = if point_velocity.norm() > 0.05 {
            (-point_velocity.normalize() + tilt).normalize()
        } else {
            to_base(&nominal, &q_at, link, &direction_in_link)
        };
        let force_base = direction * magnitude;
        if leading_side {
            let surface = safety::lwr4_link_surfaces()[link];
            let axis = (surface.to - surface.from).normalize();
            let along = point - surface.from;
            let radial = (along - axis * axis.dot(&along)).normalize();
            let normal = to_base(&nominal, &q_at, link, &radial);
            if force_base.dot(&normal) > 0.0 {
                // The opposite side's outward normal is −normal: the force pushes into it.
                point -= radial * (2.0 * surface.radius_m);
            }
        }
        let jacobian = point_jacobian(&nominal, &mut data, &q_at, link, &point);
        let jv = jacobian.fixed_rows::<3>(0).into_owned();
        let own_joint_torque = (jv.transpose() * force_base)[link].abs();
        contacts.push(Contact {
            link,
            point,
            force: force_base,
            profile: Profile::HalfSine {
                start,
                duration: duration_s,
            },
        });
        let window_end = start + duration_s + 0.1;
        records.push(ContactRecord {
            link,
            force_n: magnitude,
            start,
            own_joint_torque,
            ideal_delay_s: None,
            delay_s: None,
            onset_link: None,
            episode_link: None,
            window: (
                (start / T).floor() as usize,
                (window_end / T).ceil() as usize,
            ),
        });
    }
    ContactPlan {
        q0,
        trajectory,
        contacts,
        records,
        total_s: 1.0 + spacing * n as f64 + 1.0,
    }
}

/// `n` contacts during free motion ([`plan_contacts`]), observed by one compensated observer
/// and detector per variant.
pub fn campaign(
    seed: u64,
    n: usize,
    links: &[usize],
    force: ForceSpec,
    duration_s: f64,
    variants: &[Variant],
) -> Vec<Campaign> {
    let ContactPlan {
        q0,
        trajectory,
        contacts,
        mut records,
        total_s: total,
    } = plan_contacts(seed, n, links, force, duration_s, false);
    let mut world = World::new(seed ^ 0xC0, &q0, &contacts);
    let ticks = (total / T) as usize;
    let mut variants: Vec<(
        MomentumObserver<7>,
        CollisionDetector<7>,
        Option<usize>,
        Campaign,
    )> = variants
        .iter()
        .map(|v| {
            (
                v.observer(&world),
                v.detector(),
                None,
                Campaign {
                    label: v.label.clone(),
                    records: records.clone(),
                    series: Vec::with_capacity(ticks),
                    false_alarms: 0,
                    retriggers: 0,
                    free_hours: 0.0,
                },
            )
        })
        .collect();
    let mut free_ticks = 0usize;
    for k in 0..ticks {
        let t = k as f64 * T;
        let (input, _) = world.measure();
        let in_window = records
            .iter()
            .position(|r| k >= r.window.0 && k <= r.window.1);
        if in_window.is_none() {
            free_ticks += 1;
        }
        if let Some(i) = in_window
            && records[i].ideal_delay_s.is_none()
        {
            // Truth from the simulation: Σ J_pᵀ F of the contacts (one at a time).
            if world.sim.external_torques().amax() > THRESHOLD {
                records[i].ideal_delay_s = Some(t - records[i].start);
            }
        }
        for (obs, det, active, c) in variants.iter_mut() {
            let out = obs.step(&input);
            c.series.push(out.residual.amax() as f32);
            if k == 0 {
                continue;
            }
            match det.update(&out.residual, &out.velocity, out.cycle, t) {
                Detection::Onset(e) => match in_window {
                    Some(i) if c.records[i].delay_s.is_none() => {
                        c.records[i].delay_s = Some(t - c.records[i].start);
                        c.records[i].onset_link = Some(e.isolated_link);
                        *active = Some(i);
                    }
                    _ => {
                        let after_contact =
                            records.iter().any(|r| t > r.start && t <= r.start + 1.2);
                        if after_contact {
                            c.retriggers += 1
                        } else {
                            c.false_alarms += 1
                        }
                    }
                },
                Detection::Released { episode_link, .. } => {
                    if let Some(i) = active.take() {
                        c.records[i].episode_link = Some(episode_link);
                    }
                }
                _ => {}
            }
        }
        world.advance(&trajectory);
    }
    variants
        .into_iter()
        .map(|(_, _, _, mut c)| {
            c.free_hours = free_ticks as f64 * T / 3600.0;
            for (r, truth) in c.records.iter_mut().zip(records.iter()) {
                r.ideal_delay_s = truth.ideal_delay_s;
            }
            c
        })
        .collect()
}
