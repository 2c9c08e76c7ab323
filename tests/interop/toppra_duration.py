"""The time-optimal duration of a path under joint velocity and acceleration limits, by toppra
(TOPP-RA, Pham & Pham 2018), for tests/interop_toppra.rs; and an independent check of the pulse
tables linterpd planned for it.

Reads one JSON document on stdin:
  {"s": [...], "q": [[...], ...],          # the path: its parameter and every coordinate there
   "vmax": [...], "amax": [...],           # per coordinate (null: none)
   "vmax_along": [...] or null,            # a speed limit of the last coordinate at every s
   "gridpoints": N,
   "tables": [{"name", "max_hz", "start_hz", "accel_pulses", "begins_at_rest", "ends_at_rest",
               "start", "rows": [[freq_hz, target, direction], ...]}, ...]}
and prints {"duration_s": ..., "table_problems": [...]} on stdout.
"""

import json
import sys

import numpy as np
import toppra as ta
import toppra.algorithm as algo
import toppra.constraint as constraint

ta.setup_logging("WARNING")

BIG = 1e9


def duration(doc):
    # The path's parameter from 0 to 1 (its duration does not depend on it): in millimetres
    # toppra's solver found no controllable set on a SCARA line near full stretch.
    s = np.array(doc["s"], dtype=float)
    s = (s - s[0]) / (s[-1] - s[0])
    q = np.array(doc["q"], dtype=float)
    path = ta.SplineInterpolator(s, q)
    dof = q.shape[1]
    vmax = np.array([BIG if v is None else v for v in doc["vmax"]])
    amax = np.array([BIG if a is None else a for a in doc["amax"]])
    constraints = [
        constraint.JointVelocityConstraint(np.stack([-vmax, vmax], axis=1)),
        constraint.JointAccelerationConstraint(np.stack([-amax, amax], axis=1)),
    ]
    along = doc.get("vmax_along")
    if along is not None:
        along = np.array(along, dtype=float)

        def varying(at):
            cap = np.full(dof, BIG)
            cap[-1] = np.interp(at, s, along)
            return np.stack([-cap, cap], axis=1)

        constraints.append(constraint.JointVelocityConstraintVarying(varying))
    grid = np.linspace(s[0], s[-1], int(doc["gridpoints"]))
    instance = algo.TOPPRA(constraints, path, gridpoints=grid, parametrizer="ParametrizeConstAccel")
    trajectory = instance.compute_trajectory(0, 0)
    if trajectory is None:
        raise SystemExit("toppra found no motion within the limits")
    return float(trajectory.duration)


def table_problems(table):
    """Every row against the limits, the rows timed as the ideal model plays them: a row of n
    pulses at f Hz lasts n / f."""
    out = []
    name = table["name"]
    count = table["start"]
    rows = []
    for freq, target, direction in table["rows"]:
        pulses = abs(target - count)
        if pulses == 0:
            out.append(f"{name}: a row of no pulse")
        if (target - count) * direction < 0:
            out.append(f"{name}: a target against its direction")
        rows.append((float(freq), pulses / float(freq), direction, pulses))
        count = target
    a = table["accel_pulses"]
    for k, (f, length, way, pulses) in enumerate(rows):
        if f > table["max_hz"]:
            out.append(f"{name}: row {k} at {f} Hz above {table['max_hz']} Hz")
        turn_before = k > 0 and rows[k - 1][2] != way
        turn_after = k + 1 < len(rows) and rows[k + 1][2] != way
        # A row of one pulse is a single step, not a rate.
        rest = pulses >= 2 and ((k == 0 and table["begins_at_rest"]) or (
            k + 1 == len(rows) and table["ends_at_rest"]) or turn_before or turn_after)
        if rest and table["start_hz"] is not None and f > table["start_hz"]:
            out.append(f"{name}: row {k} at standstill {f} Hz above start_hz {table['start_hz']}")
        if rest and a is not None and f > a * length / 2 + 1 / length + 1:
            out.append(f"{name}: row {k} from or to rest at {f} Hz beyond max_accel")
        if k > 0 and not turn_before and a is not None:
            f0, l0, _, _ = rows[k - 1]
            allowed = a * (l0 + length) / 2 + 1 / l0 + 1 / length + 2
            if abs(f - f0) > allowed:
                out.append(f"{name}: rows {k - 1} and {k} step {abs(f - f0):.1f} Hz, {allowed:.1f} allowed")
    return out


def main():
    doc = json.load(sys.stdin)
    problems = [p for t in doc.get("tables", []) for p in table_problems(t)]
    json.dump({"duration_s": duration(doc), "table_problems": problems}, sys.stdout)
    print()


if __name__ == "__main__":
    main()
