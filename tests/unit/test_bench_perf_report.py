"""The report's performance sections from made-up results: bare chain ratios, composed, profile, fleet."""

from __future__ import annotations

from tests.support.bench import live, results
from zenav.bench import report
from zenav.bench.chain import Chain
from zenav.bench.fleet import HostsResult, Point
from zenav.bench.latency import END_TO_END, STAGES, Stats
from zenav.bench.profile import Cost, Hot


def bare(end_to_end: list[float], relay_cores: float, waits: tuple[float, float] = (0.0, 0.0)) -> Chain:
    """A bare chain run: 0.1 / 0.2 / 0.3 ms a stage, and `end_to_end`; `waits`: a relay's wait for a core [s], and runs a second."""
    return Chain({**{s: [0.1, 0.2, 0.3] for s in STAGES}, END_TO_END: end_to_end}, relay_cores, *waits)


def test_the_performance_sections_are_written(tmp_path):
    res = results()
    res.chains = {"client": bare([2.0, 2.5, 6.0], 0.03, (20e-6, 450.0)), "peer": bare([1.0, 1.5, 5.0], 0.02)}
    res.composed = live()
    res.composed.chain.update({s: [0.2, 0.3, 0.4] for s in STAGES})
    res.composed.chain[END_TO_END][:] = [1.0, 1.2, 3.0]
    res.costs = {"odometry": Cost("odometry", 100, 300, 100, 0.01), "localizer": Cost("localizer", 100, 300, 100, 0.03)}
    res.costs["odometry"].topics.update({"sensors/encoders": (100, 0.004), "sensors/compass": (10, 0.0001)})
    res.costs |= {n: Cost(n, 100, 100, 100, 0.005) for n in ("navigator", "motor")}
    res.costs_paced = {
        n: Cost(n, 100, c.inputs, c.outputs, c.cpu * 3.0, {t: (k, x * 2.0) for t, (k, x) in c.topics.items()}) for n, c in res.costs.items()
    }
    res.relays = (1.0, 25.0)
    res.hot = {"localizer": [Hot("localizer/model.py:99(predict)", 370, 120.0, 300.0)]}
    res.fleet = [Point(1, 0.05, 1.0, 1.0, Stats.of([1.0, 1.0])), Point(5, 0.3, 0.99, 1.0, Stats.of([2.5, 3.0]))]
    res.hosts = HostsResult(True, 2, 0.02, False)
    text = report.write(res, tmp_path).read_text()
    headings = [line for line in text.splitlines() if line.startswith("#")]
    wanted = ("### The floor: a bare chain of the same five hops", "### The robot's services composed in one process", "## Profile")
    assert all(h in headings for h in (*wanted, "## Fleet"))
    assert "- end to end (clients) / bare chain: p50 1.20x, p99 1.50x" in text  # p50 3.0 / 2.5, p99 8.88 / 5.93
    # in the targets table, per deployment, a figure and no goal: what the services add is the goal (test_bench_added)
    assert "| end to end / bare chain of its hops, clients, same windows | - | p50 1.20x, p99 1.50x | - |" in text
    assert "| end to end / bare chain of its hops, services as peers, same windows | - | p50 1.33x, p99 " in text
    assert "bare chain p50" not in text and "<= 1.3x" not in text
    # composed, the four services are one stage (their outputs leave the process in reverse order): end to end
    # less delivery, sample by sample
    composed = text[text.index("### The robot's services composed in one process") :].split("\n### ")[0]
    assert "| odometry to motor, in one process | 3 | 0.90 |" in composed  # 1.2 - 0.3 at p50
    assert "| localizer |" not in composed and "| delivery | 3 | 0.30 |" in composed
    # stage by stage beside the bare chain's, per mode: the stack's odometry p50 0.6, the bare chain's 0.2
    assert "| odometry | 0.60 / 0.20 | 0.70 / 0.30 | 0.40 / 0.20 | 0.50 / 0.30 |" in text
    # each service waited 0.03 s over 1000 runs in the 10 s window; no waits measured for the peers' bare chain
    wait = "a thread of the robot's services 30 us each time it got one, 100 times a second a service; a bare relay's 20 us, 450 times"
    assert wait in text
    assert "waiting for a core, peers" not in text
    # what serving one message took each robot service in its own process, from its diag: the localizer's two inputs
    assert "| service | input | us |\n|---|---|---|\n| localizer | odom | 180 |\n| localizer | sensors/imu | 40 |\n" in text
    assert "Delivery p50 reached 2x the one-robot figure at 5 robots." in text
    assert "The robot's services (odometry, localizer, navigator, motor): 0.050 of a core together." in text
    assert "every robot heard on every host: yes" in text
    # 500 us a period back to back, 3x paced; 4 relays 4 and 100 us
    assert "Per period the robot's services take 500 us back to back and 1500 us paced, 4 relays 4 and 100 us" in text
    assert "is 0.50 ms a period more than the relays' back to back and 1.40 ms paced" in text
    # each input by topic, the chain's first (bold); one chain sample: odometry's 40 us, 80 paced (no other service timed)
    assert "| odometry | **sensors/encoders** | 100 | 40.0 | 80.0 |\n| odometry | sensors/compass | 10 | 10.0 | 20.0 |" in text
    assert "One sample of the chain costs the robot's services 40 us back to back and 80 us paced, 4 relays 4 and 100 us." in text


def test_the_latency_note_says_what_the_services_add_over_the_bare_chain_or_that_they_were_quicker(tmp_path):
    res = results()  # end to end p50 3.0, p99 8.88 ms: over the 8 ms goal, so the note is written
    res.chains = {"client": bare([2.0, 2.5, 6.0], 0.03)}
    assert "the services' own work and queueing add the other 0.50 ms at p50" in report.write(res, tmp_path).read_text()
    res.chains = {"client": bare([3.0, 3.5, 6.0], 0.03)}
    text = report.write(res, tmp_path).read_text()
    assert "at p50 the stack took 0.50 ms less than they did" in text and "add the other -" not in text
