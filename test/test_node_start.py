# SPDX-License-Identifier: Apache-2.0
# Copyright 2026 fastslam_ros maintainers
"""What the nodes say at start and while nothing comes in: an input never received WARNs on
/diagnostics naming its resolved topic, the kernels' compilation is announced and Ctrl-C during
it ends in one line, ``publish_tf`` without tf2_ros warns once. Same style as test_node.py:
callbacks and the node clock driven directly, each test on its own Context."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest
import rclpy
from diagnostic_msgs.msg import DiagnosticStatus
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.parameter import Parameter
from rclpy.time import Time

from fastslam_ros import node_base, node_diagnostics, node_start
from fastslam_ros.core.config import numba_available
from fastslam_ros.node import FastSLAMNode
from fastslam_ros.people_node import PeopleTrackerNode
from fastslam_ros.tools.bags.in_process import in_process
from test_node import START, odometry, truth_cloud, truth_pose

DOMAIN_ID = 100 + os.getpid() % 100
BASE = {"seed": 1, "num_particles": 10, "backend": "numpy", "use_sim_time": True}


@pytest.fixture
def context():
    ctx = Context()
    rclpy.init(context=ctx, domain_id=DOMAIN_ID)
    nodes = []
    yield ctx, nodes
    for node in nodes:
        node.destroy_node()
    rclpy.shutdown(context=ctx)


def start(context, node_class=FastSLAMNode, arguments=(), namespace: str = "", live=False,
          **parameters):
    """The node driven in-process (its /diagnostics statuses collected) or a ``live`` one."""
    ctx, nodes = context
    values = {**BASE, **parameters}
    if node_class is PeopleTrackerNode:
        values.pop("backend")
    node = (node_class if live else in_process(node_class))(
        context=ctx, namespace=namespace, enable_rosout=False,
        cli_args=["--ros-args", *arguments] if arguments else None,
        parameter_overrides=[Parameter(k, value=v) for k, v in values.items()])
    nodes.append(node)
    statuses = []
    if live:
        return node, statuses
    node.output_listeners.append(
        lambda topic, msg: statuses.append(msg.status[0]) if topic == "/diagnostics" else None)
    return node, statuses


def tick(node, seconds: float) -> None:
    """The node's once-a-second timer at node time ``seconds``."""
    node.get_clock().set_ros_time_override(Time(nanoseconds=round(seconds * 1e9)))
    node._on_timer()


def test_an_input_never_received_warns_naming_its_remapped_topic(context):
    node, statuses = start(context, arguments=("-r", "odom:=/wheel/odom"), namespace="robot1")
    for second in range(5):
        tick(node, START + second)
    assert [s.level for s in statuses] == [DiagnosticStatus.OK] * 5
    assert statuses[-1].message == "running"
    tick(node, START + 5.0)
    assert statuses[-1].level == DiagnosticStatus.WARN
    assert "nothing received on /wheel/odom for 5 s" in statuses[-1].message
    assert "nothing received on /robot1/landmarks for 5 s" in statuses[-1].message
    # Odometry only: the clouds are still missing, by name.
    node.on_odometry(odometry(START + 5.5, truth_pose(0.0)))
    tick(node, START + 6.0)
    assert "/wheel/odom" not in statuses[-1].message
    assert "nothing received on /robot1/landmarks for 6 s" in statuses[-1].message
    node.on_landmarks(truth_cloud(START + 5.6))
    tick(node, START + 7.0)
    assert "nothing received" not in statuses[-1].message


def test_the_people_tracker_names_its_missing_inputs_too(context):
    node, statuses = start(context, PeopleTrackerNode, arguments=("-r", "scan:=/base_scan"),
                           scan_frame="laser")
    tick(node, START)
    tick(node, START + 5.0)
    message = statuses[-1].message
    assert statuses[-1].level == DiagnosticStatus.WARN
    assert "nothing received on /base_scan" in message and "nothing received on /odom" in message


@pytest.mark.parametrize("publish_tf, warnings", [(True, 1), (False, 0)])
def test_publish_tf_without_tf2_ros_warns_once(context, capfd, monkeypatch, publish_tf,
                                               warnings):
    monkeypatch.setattr(node_base, "TransformBroadcaster", None)
    node, _ = start(context, publish_tf=publish_tf, live=True)
    for second in range(3):
        tick(node, START + second)
    assert capfd.readouterr().err.count("tf2_ros is not installed") == warnings


def test_a_replay_node_never_warns_about_tf(context, capfd, monkeypatch):
    monkeypatch.setattr(node_base, "TransformBroadcaster", None)
    node, _ = start(context, publish_tf=True)
    tick(node, START)
    assert "tf2_ros" not in capfd.readouterr().err


@pytest.mark.skipif(not numba_available(), reason="numba is not installed: nothing compiles")
def test_the_kernels_compilation_is_announced_and_ctrl_c_ends_it_in_one_line(tmp_path):
    """A first start (an empty numba cache): the notice comes before the compilation; Ctrl-C
    during it exits with status 130 and one line, however numba takes the interrupt."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path), "ROS_DOMAIN_ID": str(DOMAIN_ID)}
    process = subprocess.Popen([sys.executable, "-m", "fastslam_ros.node", "--ros-args",
                                "-p", "backend:=numba"], stderr=subprocess.PIPE, text=True,
                               env=env)
    try:
        first = process.stderr.readline()
        assert "compiling the filter's kernels (first start only" in first
        time.sleep(1.0)  # into the compilation, past the notice's own publication on /rosout
        process.send_signal(signal.SIGINT)
        rest = process.stderr.read()
        assert process.wait(timeout=180) == 130
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
    assert rest.strip() == "fastslam_node: interrupted while starting", rest


def test_no_notice_when_nothing_compiles(context, capfd):
    start(context, backend="numpy")
    assert "compiling" not in capfd.readouterr().err


@pytest.mark.parametrize("clock", [False, True])
def test_simulated_time_without_clock_warns_once(context, capfd, monkeypatch, clock):
    """A bag played without --clock: the node's time stands still; it says so (wall time)."""
    monkeypatch.setattr(node_base, "NO_CLOCK_WARNING", 0.2)  # the timer
    monkeypatch.setattr(node_diagnostics, "NO_CLOCK_WARNING", 0.2)  # its message
    node, _ = start(context, live=True)
    if clock:
        node.get_clock().set_ros_time_override(Time(nanoseconds=round(START * 1e9)))
    executor = SingleThreadedExecutor(context=context[0])
    executor.add_node(node)
    for _ in range(100):  # bounded; ends at once when the check has run
        executor.spin_once(timeout_sec=0.05)
        if node._clock_check.is_canceled():
            break
    executor.remove_node(node)
    assert node._clock_check.is_canceled()
    assert capfd.readouterr().err.count("no /clock came in 0.2 s") == (0 if clock else 1)


BLAS_THREADS = """
from threadpoolctl import threadpool_info
from fastslam_ros.tools.cli import interruptible
import scipy.sparse.linalg  # noqa: F401 (scipy's BLAS loaded too)

def main(argv):
    print(sorted({pool["num_threads"] for pool in threadpool_info()
                  if pool["user_api"] == "blas"}))
    return 0

%s(None)
"""


@pytest.mark.parametrize("chosen", [None, "2"])
def test_a_console_command_runs_blas_on_one_thread_unless_the_user_chose(chosen):
    """numpy's and scipy's OpenBLAS start with a thread per core; a command limits them to one
    (node_start.one_blas_thread) and keeps what OPENBLAS_NUM_THREADS says when it is set: the
    threads a plain process has under that environment."""
    env = {k: v for k, v in os.environ.items() if k not in node_start.BLAS_THREAD_VARIABLES}
    if chosen is not None:
        env["OPENBLAS_NUM_THREADS"] = chosen

    def threads(call: str) -> str:
        return subprocess.run([sys.executable, "-c", BLAS_THREADS % call], env=env,
                              capture_output=True, text=True, check=True).stdout.strip()

    plain = threads("main")
    assert threads('interruptible("probe")(main)') == ("[1]" if chosen is None else plain)
