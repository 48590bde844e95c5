"""`enable_stamped_cmd_vel` from outside: the node publishes /cmd_vel as geometry_msgs/TwistStamped
(in robot_base_frame, stamped now), as Jazzy's diff_drive_controller takes it, and chassis_bridge
with the same setting drives on it. Both real binaries on a domain of their own, the sim back end
closing the loop on the bundled map."""
import math
import time

import pytest
from geometry_msgs.msg import TwistStamped
from nav_msgs.msg import Odometry
from tf2_msgs.msg import TFMessage

from conftest import ROOT, driving_rig, stamped
GOAL = (2.5, 0.3)  # 2.4 m from the simulated car's start at (0.1, 0.1), round no obstacle


@pytest.fixture(scope="module")
def stamped_rig(tmp_path_factory):
    folder = tmp_path_factory.mktemp("stamped")
    node_params = folder / "planner.yaml"
    node_params.write_text(
        f"patrol_planner:\n  ros__parameters:\n    map_yaml: {ROOT / 'config' / 'maps' / 'datacenter_100.yaml'}\n"
        "    planner: astar\n    enable_stamped_cmd_vel: true\n    robot_base_frame: base_footprint\n"
    )
    # The bridge as a launch starts it: the bundled file, a dict's file of `/**` values
    # (`parameters=[chassis.yaml, {'use_sim_time': False}]`) and a rule for its own name; only
    # that rule (applied over the file's `enable_stamped_cmd_vel: false`) lets it take
    # TwistStamped, so the car moves only when the bridge applies every source.
    launch_dict = folder / "launch_dict.yaml"
    launch_dict.write_text("/**:\n  ros__parameters:\n    use_sim_time: false\n")
    bridge_args = ("--params-file", str(launch_dict), "-p", "chassis_bridge:enable_stamped_cmd_vel:=true")
    with driving_rig(75, node_params, ROOT / "config" / "chassis.yaml", "stamped", bridge_args) as ros:
        yield ros


def test_stamped_cmd_vel_drives_the_car(stamped_rig):
    ros = stamped_rig
    odom, cmds = [], []
    ros.node.create_subscription(Odometry, "/odom", odom.append, 100)
    received = []  # when each command arrived here

    def command(m):
        cmds.append(m)
        received.append(time.time())

    ros.node.create_subscription(TwistStamped, "/cmd_vel", command, 100)
    tf = []
    ros.node.create_subscription(TFMessage, "/tf", tf.append, 100)
    # First contact between rclpy and the binaries' RustDDS: its participants announce themselves
    # every 10 s, so one lost exchange under load costs 10-20 s (a full test run timed out at 20).
    ros.spin_until(lambda: odom, 45, "/odom from the simulated chassis")
    ros.send_goal_until_planned(stamped(*GOAL))

    def arrived():
        p = odom[-1].pose.pose.position
        return math.hypot(p.x - GOAL[0], p.y - GOAL[1]) <= 0.15 and abs(odom[-1].twist.twist.linear.x) < 1e-3

    ros.spin_until(arrived, 60, "the car to reach the goal on stamped commands")
    # The bridge also broadcasts odom -> base_link on /tf: its writer is on the graph with the
    # type, and its transforms are /odom's poses (checked below). The writer comes from DDS
    # discovery itself; its node's name comes from
    # /ros_discovery_info, which can lag it under load (asking by node name timed out there):
    # until then rmw names it _NODE_NAME_UNKNOWN_ (participant known, node not yet) or
    # _CREATED_BY_BARE_DDS_APP_ (participant not yet known), so the name is given a few seconds to
    # arrive and checked once it is known. Nothing else in this rig publishes /tf.
    unknown = ("_NODE_NAME_UNKNOWN_", "_CREATED_BY_BARE_DDS_APP_")

    def tf_writers():
        return ros.node.get_publishers_info_by_topic("/tf") or None

    def named_tf_writers():
        writers = tf_writers()
        return writers if writers and all(w.node_name not in unknown for w in writers) else None

    writers = ros.spin_until(tf_writers, 30, "a /tf writer on the ROS graph")
    try:
        writers = ros.spin_until(named_tf_writers, 10, "the /tf writer's node name")
    except AssertionError:
        pass  # still unknown: the type is checked, the name cannot be
    assert [w.topic_type for w in writers] == ["tf2_msgs/msg/TFMessage"], writers
    names = [w.node_name for w in writers]
    assert all(n == "chassis_bridge" or n in unknown for n in names), names
    moving = [c for c in cmds if c.twist.linear.x > 0.05]
    assert moving, "no TwistStamped command moved the car"
    stamps = []
    for c, at in zip(cmds, received):
        assert c.header.frame_id == "base_footprint"
        stamp = c.header.stamp.sec + c.header.stamp.nanosec * 1e-9
        # Stamped as it is sent (not with the goal's or the plan's time): within half a second
        # of its arrival here, on one machine's clock.
        assert abs(at - stamp) < 0.5, f"stamp {stamp:.3f} arrived at {at:.3f}"
        stamps.append(stamp)
        assert abs(c.twist.linear.x) <= 0.6 + 1e-9 and abs(c.twist.angular.z) <= 0.4 + 1e-9
    assert all(b > a for a, b in zip(stamps, stamps[1:])), "stamps that do not increase"
    # Each odom -> base_link on /tf is the /odom pose of the same stamp, as diff_drive_controller
    # broadcasts it (the drive above moved the car, so the poses are not all the start's).
    by_stamp = {(m.header.stamp.sec, m.header.stamp.nanosec): m.pose.pose for m in odom}
    transforms = [t for m in tf for t in m.transforms]
    matched = 0
    for t in transforms:
        assert (t.header.frame_id, t.child_frame_id) == ("odom", "base_link"), t
        pose = by_stamp.get((t.header.stamp.sec, t.header.stamp.nanosec))
        if pose is None:
            continue  # its /odom message was not taken here (a reader falls behind under load)
        matched += 1
        v, q = t.transform.translation, t.transform.rotation
        assert (v.x, v.y, v.z) == (pose.position.x, pose.position.y, pose.position.z), (t, pose)
        assert (q.x, q.y, q.z, q.w) == (pose.orientation.x, pose.orientation.y, pose.orientation.z, pose.orientation.w)
    assert matched > 20 and max(t.transform.translation.x for t in transforms) > 2.0, (matched, len(transforms))


def test_the_bridge_read_every_source_and_named_what_it_passed_over(stamped_rig):
    log = (ROOT / "target" / "chassis_bridge_stamped_test.log").read_text()
    assert "parameter -p chassis_bridge:enable_stamped_cmd_vel:=true" in log, log[-2000:]
    assert "launch_dict.yaml: ignored `/**` key `use_sim_time`" in log, log[-2000:]
