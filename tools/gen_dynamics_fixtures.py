#!/usr/bin/env python3
"""Cross-check fixtures for the `dynamics` crate, computed with Pinocchio (pip install pin numpy).

The KUKA LWR 4+ is built here independently of the Rust code, from the classical DH table of
shared/docs/lwr4-model.md section 1.1 (written out below) and the link parameters of section 2.2
(read from shared/data/lwr4-golden.json, the machine-readable copy of that table).

Two Pinocchio models are built and must agree before anything is written:
  A. joint frames = classical DH frames: joint i is a revolute joint about z_{i-1}, expressed in
     DH frame i as Rx(alpha_i)^T e_z (the LWR has a_i = 0, so DH frame i lies on that axis),
     placed at Tz(d_i) Rx(alpha_i) in frame i-1. Link inertias are used as given (DH frames), so
     Pinocchio's joint torque regressor is directly in DH-frame parameters.
  B. standard RZ joints at the DH frames i-1 (rotated by q_i), with the fixed part
     Tz(d_i) Tx(a_i) Rx(alpha_i) as the next joint's placement and each link inertia moved into
     its joint frame.

Pinocchio's dynamic parameters are [m, mc_x, mc_y, mc_z, I_xx, I_xy, I_yy, I_xz, I_yz, I_zz] with
I about the joint frame origin; the Rust crate uses (m, mcx, mcy, mcz, Jxx, Jxy, Jxz, Jyy, Jyz, Jzz).
The regressor columns are reordered explicitly below (PIN_TO_RUST).

Usage: python3 tools/gen_dynamics_fixtures.py [output.json]
Default output: dynamics/tests/fixtures/pinocchio-lwr4.json
"""

import json
import os
import sys

import numpy as np
import pinocchio as pin

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
GOLDEN = os.path.join(ROOT, "..", "shared", "data", "lwr4-golden.json")
DEFAULT_OUT = os.path.join(ROOT, "dynamics", "tests", "fixtures", "pinocchio-lwr4.json")

SEED = 20170924  # IROS 2017
N_STATES = 50

# lwr4-model.md section 1.1: T_i = Rz(q_i) Tz(d_i) Tx(a_i) Rx(alpha_i)
HALF_PI = np.pi / 2.0
DH_ALPHA = [HALF_PI, -HALF_PI, -HALF_PI, HALF_PI, HALF_PI, -HALF_PI, 0.0]
DH_D = [0.0, 0.0, 0.400, 0.0, 0.390, 0.0, 0.0]
DH_A = [0.0] * 7
FLANGE_Z7 = 0.078
# lwr4-model.md section 1.2
Q_MAX_DEG = [170, 120, 170, 120, 170, 120, 170]
QD_MAX_DEG = [110, 110, 128, 128, 204, 184, 184]
QDD_MAX = 5.0  # rad/s^2, a brisk but plausible acceleration bound
G0 = 9.81

# Pinocchio parameter index for each Rust parameter index.
# Rust: m, mcx, mcy, mcz, Jxx, Jxy, Jxz, Jyy, Jyz, Jzz
# Pin : m, mcx, mcy, mcz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz
PIN_TO_RUST = [0, 1, 2, 3, 4, 5, 7, 6, 8, 9]


def rot_x(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def load_links():
    with open(GOLDEN) as f:
        golden = json.load(f)
    links = []
    for link in golden["links"]:
        xx, yy, zz, xy, xz, yz = link["I_com"]
        inertia_com = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
        links.append(pin.Inertia(link["m"], np.array(link["c"]), inertia_com))
    return links


def build_model_a(links):
    model = pin.Model()
    model.gravity = pin.Motion(np.array([0, 0, -G0, 0, 0, 0]))
    parent = 0
    for i in range(7):
        placement = pin.SE3(rot_x(DH_ALPHA[i]), np.array([DH_A[i], 0.0, DH_D[i]]))
        if DH_A[i] != 0.0:
            raise ValueError("model A needs a_i = 0")
        axis = rot_x(DH_ALPHA[i]).T @ np.array([0.0, 0.0, 1.0])
        joint = pin.JointModelRevoluteUnaligned(axis)
        parent = model.addJoint(parent, joint, placement, f"joint{i + 1}")
        model.appendBodyToJoint(parent, links[i], pin.SE3.Identity())
    flange = pin.Frame("flange", parent, 0, pin.SE3(np.eye(3), np.array([0, 0, FLANGE_Z7])),
                       pin.FrameType.OP_FRAME)
    model.addFrame(flange)
    return model


def build_model_b(links):
    model = pin.Model()
    model.gravity = pin.Motion(np.array([0, 0, -G0, 0, 0, 0]))
    parent = 0
    fixed_prev = pin.SE3.Identity()
    for i in range(7):
        parent = model.addJoint(parent, pin.JointModelRZ(), fixed_prev, f"joint{i + 1}")
        fixed = pin.SE3(rot_x(DH_ALPHA[i]), np.array([DH_A[i], 0.0, DH_D[i]]))
        # Link i lives in DH frame i = joint frame * fixed.
        model.appendBodyToJoint(parent, links[i], fixed)
        fixed_prev = fixed
    return model


def rot_z(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def generic_robot(rng):
    """A 5-joint arm exercising what the LWR does not: a_i != 0, theta offsets, prismatic joints
    and a tilted gravity vector. Classical DH rows, random physically consistent links."""
    rows = [
        {"type": "revolute", "a": 0.1, "alpha": HALF_PI, "d": 0.3, "theta": 0.2},
        {"type": "prismatic", "a": 0.05, "alpha": -HALF_PI, "d": 0.1, "theta": -0.4},
        {"type": "revolute", "a": 0.35, "alpha": 0.3, "d": -0.02, "theta": 0.0},
        {"type": "revolute", "a": 0.0, "alpha": -1.1, "d": 0.2, "theta": 1.0},
        {"type": "prismatic", "a": 0.02, "alpha": 0.0, "d": 0.05, "theta": 0.5},
    ]
    links = []
    for _ in rows:
        mass = rng.uniform(0.5, 4.0)
        com = rng.uniform(-0.15, 0.15, 3)
        moments = rng.uniform(0.005, 0.05, 3)
        moments[2] = min(moments[2], moments[0] + moments[1] - 1e-4)
        q_rand, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        inertia = q_rand @ np.diag(moments) @ q_rand.T
        links.append({"m": mass, "c": com.tolist(),
                      "I_com": [inertia[0, 0], inertia[1, 1], inertia[2, 2],
                                inertia[0, 1], inertia[0, 2], inertia[1, 2]]})
    gravity = np.array([0.8, -1.3, -9.6])
    flange = pin.SE3(rot_x(0.3) @ rot_z(-0.7), np.array([0.01, -0.02, 0.1]))

    model = pin.Model()
    model.gravity = pin.Motion(np.concatenate([gravity, np.zeros(3)]))
    parent = 0
    previous_tail = pin.SE3.Identity()
    for row, link in zip(rows, links):
        head = pin.SE3(rot_z(row["theta"]), np.zeros(3))
        if row["type"] == "revolute":
            placement = previous_tail * head
            joint = pin.JointModelRZ()
            tail = pin.SE3(np.eye(3), np.array([0, 0, row["d"]])) * \
                pin.SE3(rot_x(row["alpha"]), np.array([row["a"], 0, 0]))
        else:
            placement = previous_tail * head * pin.SE3(np.eye(3), np.array([0, 0, row["d"]]))
            joint = pin.JointModelPZ()
            tail = pin.SE3(rot_x(row["alpha"]), np.array([row["a"], 0, 0]))
        parent = model.addJoint(parent, joint, placement, f"joint{parent + 1}")
        xx, yy, zz, xy, xz, yz = link["I_com"]
        inertia = pin.Inertia(link["m"], np.array(link["c"]),
                              np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]]))
        # The link lives in DH frame i = joint frame * tail.
        model.appendBodyToJoint(parent, inertia, tail)
        previous_tail = tail
    model.addFrame(pin.Frame("flange", parent, 0, previous_tail * flange, pin.FrameType.OP_FRAME))
    data = model.createData()
    flange_id = model.getFrameId("flange")
    states = []
    for _ in range(20):
        q = rng.uniform(-1.5, 1.5, model.nq)
        qd = rng.uniform(-1.5, 1.5, model.nv)
        qdd = rng.uniform(-3, 3, model.nv)
        mass = pin.crba(model, data, q)
        mass = np.triu(mass) + np.triu(mass, 1).T
        pin.forwardKinematics(model, data, q)
        pin.updateFramePlacements(model, data)
        states.append({
            "q": q.tolist(), "qd": qd.tolist(), "qdd": qdd.tolist(),
            "M": mass.tolist(),
            "g": pin.computeGeneralizedGravity(model, data, q).tolist(),
            "tau": pin.rnea(model, data, q, qd, qdd).tolist(),
            "flange_pose": data.oMf[flange_id].homogeneous.tolist(),
        })
    return {
        "dh": rows,
        "links": links,
        "gravity": gravity.tolist(),
        "flange": {"translation": flange.translation.tolist(),
                   "rotation": flange.rotation.tolist()},
        "states": states,
    }


def main():
    out_path = sys.argv[1] if len(sys.argv) > 1 else DEFAULT_OUT
    links = load_links()
    model_a = build_model_a(links)
    model_b = build_model_b(links)
    data_a = model_a.createData()
    data_b = model_b.createData()
    rng = np.random.default_rng(SEED)
    q_max = np.radians(Q_MAX_DEG)
    qd_max = np.radians(QD_MAX_DEG)
    flange_id = model_a.getFrameId("flange")

    states = []
    for _ in range(N_STATES):
        q = rng.uniform(-q_max, q_max)
        qd = rng.uniform(-qd_max, qd_max)
        qdd = rng.uniform(-QDD_MAX, QDD_MAX, 7)

        mass = pin.crba(model_a, data_a, q)
        mass = np.triu(mass) + np.triu(mass, 1).T  # crba fills the upper triangle
        gravity = pin.computeGeneralizedGravity(model_a, data_a, q).copy()
        tau = pin.rnea(model_a, data_a, q, qd, qdd).copy()
        nle = pin.nonLinearEffects(model_a, data_a, q, qd).copy()
        coriolis = pin.computeCoriolisMatrix(model_a, data_a, q, qd).copy()
        ct_qd = coriolis.T @ qd
        qdd_fd = pin.aba(model_a, data_a, q, qd, tau).copy()
        regressor_pin = pin.computeJointTorqueRegressor(model_a, data_a, q, qd, qdd).copy()
        static_regressor_pin = pin.computeJointTorqueRegressor(
            model_a, data_a, q, np.zeros(7), np.zeros(7)).copy()
        pin.forwardKinematics(model_a, data_a, q)
        pin.updateFramePlacements(model_a, data_a)
        flange_pose = data_a.oMf[flange_id].homogeneous.copy()
        pin.computeJointJacobians(model_a, data_a, q)
        flange_jacobian = pin.getFrameJacobian(
            model_a, data_a, flange_id, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED).copy()

        # Model B must agree (independent joint representation).
        mass_b = pin.crba(model_b, data_b, q)
        mass_b = np.triu(mass_b) + np.triu(mass_b, 1).T
        assert np.max(np.abs(mass - mass_b)) < 1e-12, "model A/B mass matrices differ"
        assert np.max(np.abs(tau - pin.rnea(model_b, data_b, q, qd, qdd))) < 1e-10
        # Pinocchio's regressor is linear-exact in its own parameter order.
        p_pin = np.concatenate([model_a.inertias[j].toDynamicParameters() for j in range(1, 8)])
        assert np.max(np.abs(regressor_pin @ p_pin - tau)) < 1e-10
        # C^T qd must be the gradient of the kinetic energy (finite differences on model B).
        def kinetic(qq):
            mm = pin.crba(model_b, data_b, qq)
            mm = np.triu(mm) + np.triu(mm, 1).T
            return 0.5 * qd @ mm @ qd
        step = 1e-6
        gradient = np.array([(kinetic(q + step * e) - kinetic(q - step * e)) / (2 * step)
                             for e in np.eye(7)])
        assert np.max(np.abs(gradient - ct_qd)) < 1e-6, "C^T qd is not the energy gradient"
        assert np.max(np.abs(coriolis @ qd + gravity - nle)) < 1e-10

        regressor = np.zeros((7, 70))
        for b in range(7):
            block = regressor_pin[:, 10 * b:10 * b + 10]
            regressor[:, 10 * b:10 * b + 10] = block[:, PIN_TO_RUST]
        payload_regressor = regressor[:, 60:70]
        payload_gravity_regressor = static_regressor_pin[:, 60:64]

        states.append({
            "q": q.tolist(),
            "qd": qd.tolist(),
            "qdd": qdd.tolist(),
            "M": mass.tolist(),
            "g": gravity.tolist(),
            "tau": tau.tolist(),
            "nonlinear_effects": nle.tolist(),
            "coriolis_transpose_qd": ct_qd.tolist(),
            "forward_dynamics_qdd": qdd_fd.tolist(),
            "regressor": regressor.tolist(),
            "payload_regressor": payload_regressor.tolist(),
            "payload_gravity_regressor": payload_gravity_regressor.tolist(),
            "flange_pose": flange_pose.tolist(),
            "flange_jacobian": flange_jacobian.tolist(),
        })

    fixture = {
        "about": ("Pinocchio cross-check of the KUKA LWR 4+ (classical DH frames, lwr4-model.md), "
                  "written by tools/gen_dynamics_fixtures.py. Regressor columns per link in the "
                  "Rust order (m, mcx, mcy, mcz, Jxx, Jxy, Jxz, Jyy, Jyz, Jzz), J about the DH "
                  "frame origin. Jacobian rows (v; w) in the base frame (LOCAL_WORLD_ALIGNED). "
                  "coriolis_transpose_qd = C^T qd with Pinocchio's C (unique since Mdot = C + C^T)."),
        "pinocchio_version": pin.__version__,
        "numpy_version": np.__version__,
        "seed": SEED,
        "gravity": [0.0, 0.0, -G0],
        "states": states,
        "generic_5dof": generic_robot(np.random.default_rng(SEED + 1)),
    }
    with open(out_path, "w") as f:
        json.dump(fixture, f, indent=None, separators=(",", ":"))
        f.write("\n")
    print(f"wrote {len(states)} states to {out_path}")


if __name__ == "__main__":
    main()
