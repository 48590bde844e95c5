"""chassis_bridge's serial back end from outside: the real binary talks to a fake motor controller
on a pseudo-terminal (no hardware), written here from the protocol's description
(crates/chassis/src/protocol.rs), while rclpy drives it on /cmd_vel and reads /odom. The
board obeys the $CMD lines and reports $ENC counts; the test checks every command the board got
against the 0.6 m/s and 0.4 rad/s limits, /odom against the board's true pose, the stop when
/cmd_vel stops, and that /odom pauses while the board is silent and comes back after."""
import math
import os
import pty
import select
import threading
import time
import tty

import pytest
import rclpy
from geometry_msgs.msg import Twist, Vector3
from nav_msgs.msg import Odometry

from conftest import ROOT, Ros, domain_id, start_bridge, stop_binary

R, B, TICKS = 0.08, 0.40, 2048.0  # config/chassis.yaml's wheel radius, separation, encoder counts


def nmea(body):
    s = 0
    for ch in body.encode():
        s ^= ch
    return f"${body}*{s:02X}\r\n"


class FakeBoard(threading.Thread):
    """A motor controller: obeys $CMD, integrates its wheels every 20 ms of its own clock, reports
    $ENC (unless silent), and keeps its true pose."""

    def __init__(self, master):
        super().__init__(daemon=True)
        self.master, self.stop, self.silent = master, threading.Event(), threading.Event()
        self.commands, self.lock = [], threading.Lock()
        self.wl = self.wr = self.al = self.ar = 0.0
        self.x = self.y = self.yaw = 0.0
        self.ms, self.pending = 0, b""
        os.write(master, b"motor board v1.2 booting\r\n")  # a banner the bridge must skip

    def run(self):
        while not self.stop.is_set():
            while select.select([self.master], [], [], 0)[0]:
                try:
                    self.pending += os.read(self.master, 4096)
                except OSError:
                    return
            while b"\n" in self.pending:
                line, self.pending = self.pending.split(b"\n", 1)
                line = line.decode().strip()
                body, cs = line[1:].split("*")
                assert line.startswith("$") and nmea(body).strip() == line, line
                name, left, right = body.split(",")
                assert name == "CMD", line
                with self.lock:
                    self.wl, self.wr = float(left), float(right)
                    self.commands.append((time.time(), self.wl, self.wr))
            time.sleep(0.02)
            with self.lock:
                self.ms += 20
                self.al += self.wl * 0.02
                self.ar += self.wr * 0.02
                v, w = R * (self.wr + self.wl) / 2, R * (self.wr - self.wl) / B
                mid = self.yaw + w * 0.01
                self.x += v * 0.02 * math.cos(mid)
                self.y += v * 0.02 * math.sin(mid)
                self.yaw += w * 0.02
                counts = [int(round(a / (2 * math.pi) * TICKS)) for a in (self.al, self.ar)]
            if not self.silent.is_set():
                os.write(self.master, nmea(f"ENC,{self.ms},{counts[0]},{counts[1]}").encode())


@pytest.fixture(scope="module")
def rig(tmp_path_factory):
    master, slave = pty.openpty()
    tty.setraw(slave)  # no echo of the board's lines back to it before the bridge opens the port
    device = os.ttyname(slave)
    params = tmp_path_factory.mktemp("serial") / "chassis.yaml"
    params.write_text(
        "chassis_bridge:\n  ros__parameters:\n    backend: serial\n    initial_pose: [0.0, 0.0, 0.0]\n"
        f"    serial:\n      device: {device}\n"
    )
    domain = domain_id(25)  # the bridge alone, away from the `ros` fixture's node
    board = FakeBoard(master)
    board.start()
    proc = start_bridge(domain, params, "chassis_bridge_serial_test.log", "info")
    ros = Ros(domain, context=rclpy.Context())
    try:
        yield ros, board, proc
    finally:
        ros.close()
        try:
            stop_binary(proc)
        finally:
            board.stop.set()
            board.join(timeout=5)
            os.close(master)
            os.close(slave)


def test_the_serial_chassis_obeys_within_limits_and_reports_odometry(rig):
    ros, board, proc = rig
    odom = []
    ros.node.create_subscription(Odometry, "/odom", odom.append, 100)
    cmd_pub = ros.node.create_publisher(Twist, "/cmd_vel", 10)
    ros.wait_matched(cmd_pub, "/cmd_vel")
    ros.spin_until(lambda: odom, 45, "/odom from the serial chassis")

    # 2 s of a command beyond the limits: 1 m/s and 1 rad/s.
    end = time.time() + 2.0
    while time.time() < end:
        cmd_pub.publish(Twist(linear=Vector3(x=1.0), angular=Vector3(z=1.0)))
        ros.spin_for(0.05)
    cut = time.time()
    stopped = ros.spin_until(
        lambda: next((t for t, l, r in board.commands if t > cut and l == 0.0 and r == 0.0), None), 3, "a $CMD 0,0"
    )
    assert stopped - cut <= 0.5 + 0.25, f"the board got its stop {stopped - cut:.2f} s after the last /cmd_vel"

    with board.lock:
        commands = list(board.commands)
        truth = (board.x, board.y, board.yaw)
    moving = [(l, r) for _, l, r in commands if l or r]
    assert len(moving) > 50, f"{len(moving)} driving commands reached the board"
    for left, right in moving:
        v, w = R * (right + left) / 2, R * (right - left) / B
        assert abs(v) <= 0.6 + 1e-3 and abs(w) <= 0.4 + 1e-3, f"$CMD {left}, {right} is {v:.3f} m/s, {w:.3f} rad/s"
    assert any(abs(R * (r + l) / 2 - 0.6) < 1e-3 for l, r in moving), "the speed reached the 0.6 m/s limit"
    assert truth[0] > 0.3 and truth[2] > 0.3, f"the board drove: {truth}"

    # /odom is the board's pose, from its encoders (to a count's worth, 0.25 mm per wheel).
    ros.spin_for(0.5)
    p = odom[-1].pose.pose
    yaw = 2 * math.atan2(p.orientation.z, p.orientation.w)
    assert odom[-1].header.frame_id == "odom" and odom[-1].child_frame_id == "base_link"
    assert abs(p.position.x - truth[0]) < 0.01 and abs(p.position.y - truth[1]) < 0.01 and abs(yaw - truth[2]) < 0.01, (
        f"/odom ({p.position.x:.3f}, {p.position.y:.3f}, {yaw:.3f}) vs board {truth}"
    )

    # The board goes quiet: /odom pauses (the planner's follower then stops), the bridge lives on.
    board.silent.set()
    ros.spin_for(0.3)
    paused_at = len(odom)
    ros.spin_for(1.5)
    assert len(odom) == paused_at, "/odom went on without encoder readings"
    assert proc.poll() is None
    board.silent.clear()
    ros.spin_until(lambda: len(odom) > paused_at + 5, 10, "/odom after the board speaks again")
    log = (ROOT / "target" / "chassis_bridge_serial_test.log").read_text()
    assert "not a sentence" in log, "the boot banner was reported"
    assert "no odometry from the chassis" in log and "odometry from the chassis again" in log


def test_a_missing_device_is_retried_and_the_bridge_keeps_serving(tmp_path):
    params = tmp_path / "chassis.yaml"
    params.write_text("chassis_bridge:\n  ros__parameters:\n    backend: serial\n    serial:\n      device: /dev/patrol-no-such-tty\n")
    log_path = ROOT / "target" / "chassis_bridge_no_device_test.log"
    proc = start_bridge(domain_id(26), params, log_path.name)
    deadline = time.time() + 20
    while time.time() < deadline and "cannot open" not in log_path.read_text():
        time.sleep(0.1)
    time.sleep(2.5)  # two more retries
    assert proc.poll() is None, "the bridge gave up on a missing device"
    stop_binary(proc)
    text = log_path.read_text()
    assert text.count("cannot open /dev/patrol-no-such-tty") == 1, "one error per outage, not one per retry"
    assert "retrying every 1 s" in text
