# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""``/diagnostics`` of the package's nodes: once a second, every input counter, the input
gaps and the processing lag, WARN with the reason when input was dropped, an input is silent
or was never received, or the node cannot do its job (``DiagnosticsReporting``, part of
``FilterNode``)."""
from __future__ import annotations

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from std_msgs.msg import Header

from fastslam_ros import ros_io

LAG_WARNING = 1.0
"""s: a reading processed this long after its stamp (node time) makes the diagnostics WARN."""
DIAGNOSTICS_PERIOD = 1.0
"""Seconds of node time between two /diagnostics messages."""
NO_INPUT_WARNING = 5.0
"""s of node time after the first /diagnostics report: an input still never received then
makes the diagnostics WARN, naming its topic."""
NO_CLOCK_WARNING = 5.0
"""s of wall time after start: a node on simulated time whose clock has not moved warns."""


class DiagnosticsReporting:
    """``FilterNode``'s /diagnostics: what went wrong since the last report, and what still is."""

    def _new_problems(self, now: float) -> list[str]:
        """What went wrong since the last report, worst first: drops, input gaps, silence,
        processing lag, then the node's ``diagnosed`` counters."""
        stats, seen = self.stats, self._reported
        drops = sum(v for k, v in stats.items() if k.startswith("dropped_"))
        counts = {"drops": drops, **{f"{topic}_missing": stats[f"{topic}_missing"]
                                     for topic in self._rates},
                  **{key: stats[key] for key, _ in self._diagnosed}}
        new = {k: v - seen.get(k, 0) for k, v in counts.items()}
        self._reported = counts
        problems = []
        if new["drops"]:
            problems.append(f"{new['drops']} input(s) dropped")
        for topic, rate in self._rates.items():
            if new[f"{topic}_missing"] > 0:
                problems.append(f"~{new[f'{topic}_missing']} {topic} message(s) lost (gaps in "
                                f"the stamps up to {rate.largest_gap:.3g} s, usual interval "
                                f"{rate.interval:.3g} s)")
            if silent := rate.silence(now):
                problems.append(f"no {topic} for {silent:.3g} s (usual interval "
                                f"{rate.interval:.3g} s)")
        problems += self._never_received(now)
        if self._worst_lag > LAG_WARNING:
            problems.append(f"processing lag {self._worst_lag:.3g} s behind the stamps")
        problems += [f"{new[key]} {what}" for key, what in self._diagnosed if new[key]]
        return problems

    def _never_received(self, now: float) -> list[str]:
        """The inputs of which not one message came in NO_INPUT_WARNING s after the first
        report, by their resolved (namespaced, remapped) names: a wrong topic or namespace."""
        if self._first_report is None:
            self._first_report = now
        waited = now - self._first_report
        if waited < NO_INPUT_WARNING:
            return []
        return [f"nothing received on {self.resolve_topic_name(topic)} for {waited:.3g} s"
                for topic in self._rates if not self.stats.get(f"received_{topic}")]

    def _publish_diagnostics(self, component: str = "filter") -> None:
        """/diagnostics: every counter, the node's state, the input rates and the processing
        lag; WARN naming what went wrong since the last report and what still is wrong."""
        now_ns = self._now_ns()
        now = now_ns * 1e-9
        new = self._new_problems(now)
        problems = self._standing_problems() + (["; ".join(new) + " since last report"]
                                                if new else [])
        rates = [KeyValue(key=f"{topic}_{name}", value=f"{value:.6g}")
                 for topic, rate in self._rates.items()
                 for name, value in (("interval", rate.interval or 0.0),
                                     ("largest_gap", rate.largest_gap),
                                     ("silent_for", rate.silence(now)))]
        timing = [KeyValue(key="processing_lag_max", value=f"{self._worst_lag:.6g}"),
                  KeyValue(key="callback_time_max", value=f"{self._worst_callback:.6g}")]
        self._worst_lag = self._worst_callback = 0.0
        status = DiagnosticStatus(
            level=DiagnosticStatus.WARN if problems else DiagnosticStatus.OK,
            name=f"{self.get_name()}: {component}", hardware_id=self.get_fully_qualified_name(),
            message="; ".join(problems) or "running",
            values=[self._counter_value(k, v) for k, v in self.stats.items()]
            + self._diagnostic_state() + rates + timing)
        self._publish(self._diagnostics_pub, DiagnosticArray(
            header=Header(stamp=ros_io.nanoseconds_to_stamp(now_ns)), status=[status]))

    def _counter_value(self, key: str, count: int) -> KeyValue:
        """The KeyValue of a counter: the one of the last report while the count is the same
        (most counters stay put; no report changes a KeyValue)."""
        cached = self._counter_values.get(key)
        if cached is None or cached[0] != count:
            cached = self._counter_values[key] = (count, KeyValue(key=key, value=str(count)))
        return cached[1]


    def _check_clock(self) -> None:
        """Once, NO_CLOCK_WARNING s of wall time after start: on simulated time with no /clock
        (a bag played without --clock) the node's time stands still, its timer never runs and
        it would say nothing at all."""
        self._clock_check.cancel()
        if (self.get_parameter("use_sim_time").value
                and self.get_clock().now().nanoseconds == 0):
            self.get_logger().warning(
                f"use_sim_time is true but no /clock came in {NO_CLOCK_WARNING:g} s: the node's "
                "time stands still and it outputs nothing (play a bag with --clock, or set "
                "use_sim_time false)")
