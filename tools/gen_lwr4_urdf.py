#!/usr/bin/env python3
"""Writes dynamics/robots/lwr4.urdf: the KUKA LWR 4+ in the usual URDF layout
(CentroEPiaggio/FloBaRoID: link i's frame on joint i, z up at q = 0; joint offsets 0.11, 0.2005,
0.20, 0.20, 0.20, 0.19, 0.078 m) with the nominal link parameters of lwr4-model.md section 2.2
moved from the classical DH frames into the URDF link frames with the constant poses of section 1.4
(c_URDF = R c_DH + p, I_URDF = R I_DH R^T about the CoM). Pure Python, no dependencies.

Usage: python3 tools/gen_lwr4_urdf.py [output.urdf]
"""

import json
import math
import os
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
GOLDEN = os.path.join(ROOT, "..", "shared", "data", "lwr4-golden.json")
DEFAULT_OUT = os.path.join(ROOT, "dynamics", "robots", "lwr4.urdf")

OFFSETS = [0.11, 0.2005, 0.20, 0.20, 0.20, 0.19, 0.078]
# Joint axes in the URDF link frames: DH joint i turns about z_{i-1} = R_i Rx(alpha_i)^T e_z.
AXES = ["0 0 1", "0 -1 0", "0 0 1", "0 1 0", "0 0 1", "0 -1 0", "0 0 1"]
# Section 1.4: pose (Rx angle in degrees, z translation) of DH frame i in URDF link frame i.
# Link 1 uses 0.2005 (the CentroEPiaggio joint-2 offset) so that the DH shoulder is at joint 2.
DH_IN_URDF = [(90, 0.2005), (0, 0.0), (-90, 0.20), (0, 0.0), (90, 0.19), (0, 0.0), (0, -0.078)]
Q_MAX_DEG = [170, 120, 170, 120, 170, 120, 170]
QD_MAX_DEG = [110, 110, 128, 128, 204, 184, 184]
TAU_MAX = [176, 176, 100, 100, 100, 38, 38]


def rot_x(deg):
    a = math.radians(deg)
    c, s = math.cos(a), math.sin(a)
    if abs(c) < 1e-15:
        c = 0.0
    return [[1, 0, 0], [0, c, -s], [0, s, c]]


def matmul(a, b):
    return [[sum(a[i][k] * b[k][j] for k in range(3)) for j in range(3)] for i in range(3)]


def transpose(a):
    return [[a[j][i] for j in range(3)] for i in range(3)]


def fmt(x):
    return repr(float(x))


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else DEFAULT_OUT
    with open(GOLDEN) as f:
        links = json.load(f)["links"]
    lines = ['<?xml version="1.0"?>',
             "<!-- KUKA LWR 4+ for the dynamics crate: written by tools/gen_lwr4_urdf.py from",
             "     shared/docs/lwr4-model.md (sections 1.2, 1.4, 2.2). Do not edit by hand. -->",
             '<robot name="lwr4">',
             '  <link name="base_link"/>']
    parent = "base_link"
    for i in range(7):
        link = links[i]
        angle, z = DH_IN_URDF[i]
        r = rot_x(angle)
        c = link["c"]
        com = [sum(r[k][j] * c[j] for j in range(3)) + (z if k == 2 else 0.0) for k in range(3)]
        xx, yy, zz, xy, xz, yz = link["I_com"]
        inertia = matmul(matmul(r, [[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]]), transpose(r))
        name = f"lwr_link_{i + 1}"
        lines += [
            f'  <joint name="lwr_joint_{i + 1}" type="revolute">',
            f'    <parent link="{parent}"/>',
            f'    <child link="{name}"/>',
            f'    <origin xyz="0 0 {fmt(OFFSETS[i])}" rpy="0 0 0"/>',
            f'    <axis xyz="{AXES[i]}"/>',
            f'    <limit lower="{fmt(-math.radians(Q_MAX_DEG[i]))}" upper="{fmt(math.radians(Q_MAX_DEG[i]))}"'
            f' effort="{fmt(TAU_MAX[i])}" velocity="{fmt(math.radians(QD_MAX_DEG[i]))}"/>',
            "  </joint>",
            f'  <link name="{name}">',
            "    <inertial>",
            f'      <origin xyz="{fmt(com[0])} {fmt(com[1])} {fmt(com[2])}" rpy="0 0 0"/>',
            f'      <mass value="{fmt(link["m"])}"/>',
            f'      <inertia ixx="{fmt(inertia[0][0])}" ixy="{fmt(inertia[0][1])}" ixz="{fmt(inertia[0][2])}"'
            f' iyy="{fmt(inertia[1][1])}" iyz="{fmt(inertia[1][2])}" izz="{fmt(inertia[2][2])}"/>',
            "    </inertial>",
            "  </link>",
        ]
        parent = name
    lines.append("</robot>")
    with open(out, "w") as f:
        f.write("\n".join(lines) + "\n")
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
