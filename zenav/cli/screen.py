"""The one-screen status of `zenav up` and `zenav status` (pure text formatting)."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

from zenav.common.geometry import wrap_angle


def fmt_pose(msg: Any) -> str:
    return f"x {msg.x:+7.3f}  y {msg.y:+7.3f}  th {math.degrees(msg.theta):+7.1f} deg"


def pose_line(label: str, msg: Any, truth: Any) -> str:
    """A pose with its distance and heading difference to the latest truth (and SLIPPING while the localizer finds
    the wheels slipping)."""
    if msg is None:
        return f"{label:<6} (none yet)"
    line = f"{label:<6} {fmt_pose(msg)}"
    if truth is not None and label != "truth":
        err = math.hypot(msg.x - truth.x, msg.y - truth.y)
        dth = math.degrees(wrap_angle(msg.theta - truth.theta))
        line += f"   vs truth {err * 100:6.2f} cm {dth:+6.2f} deg"
    elif label == "truth":
        line += f"   v {msg.v:+.3f} m/s  w {msg.omega:+.2f} rad/s"
    if getattr(msg, "slipping", False):
        line += "   SLIPPING (held or pushed?)"
    return line


# Input a service counted and let go unserved, besides bad input: stale or future stamps, a full
# queue, superseded by a newer sample (a service slower than its input), oversize.
DROPPED = ("dropped_stale", "dropped_future", "dropped_overflow", "dropped_superseded", "oversize")


def rate(topic: str, hz: float, serve: Mapping[str, float]) -> str:
    """A topic's rate, and for an input what serving one of its messages took the service."""
    us = serve.get(topic)
    return f"{topic} {hz:.0f}" + (f" ({us:.0f} us)" if us is not None else "")


def service_rows(names: Sequence[str], diags: Mapping[str, Any], alive: set[str], sup: Any | None = None) -> list[str]:
    head = f"{'service':<10} {'alive':<5} {'status':<9} {'restarts':>8}  {'in/out':>13} {'bad':>4} {'dropped':>7} {'cpu':>6}"
    rows = [f"{head}  rates [Hz] (serving one [us])"]
    for n in names:
        d = diags.get(n)
        d = d.msg if d is not None and hasattr(d, "msg") else d
        child = sup.children.get(n) if sup is not None else None
        restarts = str(child.restarts) if child is not None else "-"
        status = d.status if d is not None else "-"
        io = f"{d.counters.get('msgs_in', 0)}/{d.counters.get('msgs_out', 0)}" if d is not None else "-"
        bad = str(d.counters.get("bad_input", 0)) if d is not None else "-"
        dropped = str(sum(d.counters.get(k, 0) for k in DROPPED)) if d is not None else "-"
        cpu = f"{d.cpu * 100:.1f}%" if d is not None and d.cpu is not None else "-"  # of one core, the process's
        rates = ", ".join(rate(k, v, d.serve) for k, v in sorted(d.rates.items()) if not k.startswith("diag/")) if d else ""
        up = "yes" if n in alive else "NO"
        rows.append(f"{n:<10} {up:<5} {status:<9} {restarts:>8}  {io:>13} {bad:>4} {dropped:>7} {cpu:>6}  {rates}")
        if d is not None and d.message:
            rows.append(f"{'':<10} {d.message}")
    return rows


def render(
    robot: str,
    endpoint: str,
    scenario: str,
    sup: Any,
    topics: Mapping[str, Any],
    diags: Mapping[str, Any],
    alive: set[str],
    events: Sequence[str],
) -> str:
    """The whole screen of `zenav up`."""
    truth = topics["sim/truth"].msg
    nav = topics["nav/state"].msg
    t = f"t {truth.t:8.2f} s" if truth is not None else "t -"
    lines = [f"zenav up  robot {robot}  router {endpoint}  scenario {scenario}  {t}   (Ctrl-C stops all)", ""]
    lines += service_rows(list(sup.children), diags, alive, sup)
    lines.append("")
    lines.append(pose_line("truth", truth, None))
    lines.append(pose_line("odom", topics["odom"].msg, None) + "   (odom frame)")
    lines.append(pose_line("pose", topics["pose"].msg, truth))
    if nav is not None:
        dist = f"{nav.distance_remaining:.3f} m" if nav.distance_remaining is not None else "-"
        lines.append(f"nav    {nav.state}  goal {nav.goal_id}  remaining {dist}  result {nav.result or '-'}")
    lines.append("")
    lines += list(events)
    return "\n".join(lines)
