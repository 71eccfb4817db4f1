//! Shaping of the application's wish into a command the controller accepts: command flags
//! frozen in command mode, the mirrored set-point outside it, per-cycle step limits and gain
//! clamps, with every correction counted.

use super::{
    DEFAULT_JOINT_DAMPING, DEFAULT_JOINT_STIFFNESS, DesiredCommand, LimitCounters, Session,
    SessionConfig,
};
use crate::handshake::{HandshakeRequest, KrlStrategy};
use crate::wire::{Command, CommandFlags, InterfaceState, JOINTS, Measurement};

/// The command for `msr`, with every rule applied (header counters filled by the caller);
/// `reflected` tells whether the controller applied `previous` in the cycle before `msr`.
#[allow(clippy::too_many_arguments)]
pub(super) fn build(
    config: &SessionConfig,
    limits: &mut LimitCounters,
    frozen_flags: &mut Option<CommandFlags>,
    previous: Option<&Command>,
    reflected: bool,
    selected_strategy: KrlStrategy,
    request: &HandshakeRequest,
    msr: &Measurement,
    desired: &DesiredCommand,
) -> Command {
    let commanding = Session::commanding(msr);

    // Command flags: selected strategy in monitor mode, frozen in command mode.
    let wanted_flags = selected_strategy.command_flags();
    let cmd_flags = if msr.interface.state == InterfaceState::Command {
        let frozen = *frozen_flags.get_or_insert(match previous {
            Some(p) => p.cmd_flags,
            // Joined while already in command mode: keep what the controller runs.
            None => msr.robot.control.command_flags(),
        });
        if frozen != wanted_flags {
            limits.flag_changes_blocked += 1;
        }
        frozen
    } else {
        *frozen_flags = None;
        wanted_flags
    };

    let mirrored = msr.mirrored_joint_position();
    let (jnt_pos, add_jnt_trq) = if commanding {
        // Step limits start from the set-point the controller holds now: our previous reply
        // when the controller applied it in the last cycle, otherwise the controller's own
        // set-point cmdJntPos + cmdJntPosFriOffset, which after missed answers is its
        // extrapolation of our last step. Stepping from our unreceived reply instead
        // would pull the controller back by the bridged steps: a set-point jump.
        let base_pos = match previous {
            Some(p) if reflected => p.jnt_pos,
            _ => mirrored,
        };
        let base_trq = previous.map_or([0.0; JOINTS], |p| p.add_jnt_trq);
        let target = desired.joint_position.unwrap_or(base_pos);
        let pos = limit_steps(
            &base_pos,
            &target,
            config.max_joint_step,
            &mut limits.joint_steps_clamped,
            &mut limits.non_finite_desired,
        );
        let trq = limit_steps(
            &base_trq,
            &desired.added_torque,
            config.max_added_torque_step,
            &mut limits.added_torque_steps_clamped,
            &mut limits.non_finite_desired,
        );
        (pos, trq)
    } else {
        let overridden = desired.joint_position.is_some_and(|q| q != mirrored)
            || desired.added_torque.iter().any(|t| *t != 0.0);
        if overridden {
            limits.mirrored_overrides += 1;
        }
        (mirrored, [0.0; JOINTS])
    };

    let jnt_stiffness = clamp_gains(
        &desired.joint_stiffness,
        config.max_joint_stiffness,
        DEFAULT_JOINT_STIFFNESS,
        limits,
    );
    let jnt_damping = clamp_gains(&desired.joint_damping, 1.0, DEFAULT_JOINT_DAMPING, limits);

    let mut krl = desired.krl;
    for v in &mut krl.real {
        if !(*v as f32).is_finite() {
            *v = 0.0;
            limits.non_finite_desired += 1;
        }
    }
    krl.fill = 0;
    request.write_to(&mut krl);

    Command {
        header: Default::default(),
        krl,
        cmd_flags,
        jnt_pos,
        // Cartesian fields are not commanded by this session; keep them valid and neutral.
        cart_pos: msr.data.msr_cart_pos,
        add_jnt_trq,
        add_tcp_ft: [0.0; 6],
        jnt_stiffness,
        jnt_damping,
        cart_stiffness: [1000.0, 1000.0, 1000.0, 100.0, 100.0, 100.0],
        cart_damping: [0.7; 6],
    }
}

/// Moves each element from `base` towards `target` by at most `max_step`; non-finite targets
/// keep the base value. Counts clamped and non-finite elements.
fn limit_steps(
    base: &[f64; JOINTS],
    target: &[f64; JOINTS],
    max_step: f64,
    clamped: &mut u64,
    non_finite: &mut u64,
) -> [f64; JOINTS] {
    core::array::from_fn(|i| {
        let t = target[i];
        if !(t as f32).is_finite() {
            *non_finite += 1;
            return base[i];
        }
        let step = t - base[i];
        if step.abs() > max_step {
            *clamped += 1;
            base[i] + max_step.copysign(step)
        } else {
            t
        }
    })
}

/// Clamps gains into 0…max; non-finite elements take `neutral`. Counts corrections.
fn clamp_gains(
    gains: &[f64; JOINTS],
    max: f64,
    neutral: f64,
    limits: &mut LimitCounters,
) -> [f64; JOINTS] {
    gains.map(|g| {
        if !g.is_finite() {
            limits.non_finite_desired += 1;
            neutral
        } else if !(0.0..=max).contains(&g) {
            limits.gains_clamped += 1;
            g.clamp(0.0, max)
        } else {
            g
        }
    })
}
