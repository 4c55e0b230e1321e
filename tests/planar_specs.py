"""Small linkage specs written inline for engine tests (the example mechanisms are in examples/)."""

from __future__ import annotations

FOURBAR = """\
name: four-bar
units: mm
joints:
  O: [0, 0]
  A: [1, 0]
  B: [2.2, 2.1]
  D: [3, 0]
ground: [O, D]
links:
  crank: [O, A]
  coupler: [A, B]
  rocker: [D, B]
motor: {joint: A, pivot: O}
tracks:
  tip: {joint: B}
  coupler_point: {link: coupler, at: [1.2, 1.6]}
"""

# A class-III Assur group: a ternary link T1-T2-T3 hung from two ground pivots and the crank tip.
TRIAD = """\
name: triad
units: mm
joints:
  O: [0, 0]
  A: [1, 0]
  P1: [-3, 0]
  P2: [4, 0]
  T1: [-1.5, 3]
  T2: [2.5, 3]
  T3: [0.5, 2]
ground: [O, P1, P2]
links:
  crank: [O, A]
  l1: [P1, T1]
  l2: [P2, T2]
  l3: [A, T3]
  body: [T1, T2, T3]
motor: {joint: A, pivot: O}
"""

# Two dyads sharing nothing: five-bar with one motor has mobility 2.
FIVEBAR = """\
name: five-bar
units: mm
joints:
  O: [0, 0]
  A: [1, 0]
  B: [1.5, 2]
  C: [3.5, 2]
  D: [4, 0]
ground: [O, D]
links:
  crank: [O, A]
  l1: [A, B]
  l2: [B, C]
  l3: [C, D]
motor: {joint: A, pivot: O}
"""

# Non-Grashof: the crank cannot turn fully (locks up for part of the turn).
LOCKING = FOURBAR.replace("A: [1, 0]", "A: [1.9, 0]")


# Jansen's leg with the rest pose rounded as in the issue (the exact one is examples/jansen.yaml).
JANSEN = """\
name: jansen
units: mm
joints:
  O: [0, 0]
  A: [15, 0]
  B: [-38, -7.8]
  C: [-24.0135, 31.2721]
  D: [-26.9521, -45.5152]
  E: [-74.7944, 8.1432]
  F: [-59.2315, -28.0529]
  G: [-43.1601, -91.7569]
ground: [O, B]
links:
  crank: [O, A]
  AC: [A, C]
  AD: [A, D]
  BCE: [B, C, E]
  BD: [B, D]
  EF: [E, F]
  DFG: [D, F, G]
motor: {joint: A, pivot: O}
tracks:
  foot: {joint: G}
"""
