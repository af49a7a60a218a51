"""A KUKA KR6-like arm written as URDF from a standard DH table, angles to 15 digits.

``T_i = Rz(theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i)``: joint ``i + 1`` sits at ``xyz = (a_i, 0,
d_i)``, ``rpy = (alpha_i, 0, 0)`` in the frame of joint ``i`` (after its rotation), every joint
turns about its ``z``; ``tool0`` follows joint 6 by ``(a_6, 0, d_6)``, ``alpha_6``. The right
angles are written as ``1.57079632679490`` (15 significant digits), 3.4e-15 from pi/2: a
model whose structure (perpendicular axes, a spherical wrist) holds only to that, as a URDF
written by hand from a data sheet does. :data:`URDF` is ``tests/data/kr6_dh15.urdf``
(``tests/formulation/test_enclosures.py`` checks that the file is this text).
"""

from __future__ import annotations

import mpmath as mp

HALF_PI = "1.57079632679490"
#: (d, a, alpha) per link, as written in the file
DH = [
    ("0.4", "0.025", "-" + HALF_PI),
    ("0", "0.455", "0"),
    ("0", "0.035", "-" + HALF_PI),
    ("0.42", "0", HALF_PI),
    ("0", "0", "-" + HALF_PI),
    ("0.08", "0", "0"),
]

#: ``(d, a, alpha)`` rows as written: a spherical wrist with lines 2 and 3 parallel (KR6-like)
#: with twists of 60 and 45 degrees, and a UR-like arm (lines 2, 3, 4 parallel) with twists of
#: no right angle at all
TWISTED = {
    "wrist-parallel": [
        ("0.4", "0.025", "-1.0471975511966"),
        ("0", "0.455", "0"),
        ("0", "0.035", "-" + HALF_PI),
        ("0.42", "0", "0.785398163397448"),
        ("0", "0", "-" + HALF_PI),
        ("0.08", "0", "0.3"),
    ],
    "parallel": [
        ("0.089159", "0", "1.2"),
        ("0", "-0.425", "0"),
        ("0", "-0.39225", "0"),
        ("0.10915", "0", "1.3"),
        ("0.09465", "0", "-1.1"),
        ("0.0823", "0", "0.2"),
    ],
}


def urdf(dh: list | None = None, name: str = "kr6_dh15") -> str:
    """The URDF of the DH table ``dh`` (rows ``(d, a, alpha)`` as written; :data:`DH` if None)."""
    dh = DH if dh is None else dh
    links = "".join(f'  <link name="link{i}"/>\n' for i in range(7)) + '  <link name="tool0"/>\n'
    joints = []
    prev = ("0", "0", "0")  # joint 1 at the base
    for i in range(6):
        d, a, al = prev
        joints.append(
            f'  <joint name="joint{i + 1}" type="revolute">\n'
            f'    <parent link="link{i}"/>\n    <child link="link{i + 1}"/>\n'
            f'    <origin xyz="{a} 0 {d}" rpy="{al} 0 0"/>\n    <axis xyz="0 0 1"/>\n'
            f'    <limit lower="-6.28318530717959" upper="6.28318530717959" effort="1" velocity="1"/>\n'
            "  </joint>\n"
        )
        prev = dh[i]
    d, a, al = prev
    joints.append(
        '  <joint name="tool0_joint" type="fixed">\n'
        '    <parent link="link6"/>\n    <child link="tool0"/>\n'
        f'    <origin xyz="{a} 0 {d}" rpy="{al} 0 0"/>\n'
        "  </joint>\n"
    )
    return f'<?xml version="1.0"?>\n<robot name="{name}">\n' + links + "".join(joints) + "</robot>\n"


URDF = urdf()


def exact_placements():
    """Per joint and for ``tool0``: ``(R, t)`` at mpmath's precision from the numbers as written
    (each read as the binary64 number it denotes, then exact)."""
    out = []
    prev = ("0", "0", "0")
    for i in range(7):
        d, a, al = prev
        c, s = mp.cos(mp.mpf(float(al))), mp.sin(mp.mpf(float(al)))
        R = mp.matrix([[1, 0, 0], [0, c, -s], [0, s, c]])
        out.append((R, mp.matrix([mp.mpf(float(a)), 0, mp.mpf(float(d))])))
        if i < 6:
            prev = DH[i]
    return out
