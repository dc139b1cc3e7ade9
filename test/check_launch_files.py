#!/usr/bin/python3
"""Resolves the launch files with roslaunch's own loader (no master, no nodes started) and checks
what they would start: live_camera.launch's topic layouts (realsense, openni, an unknown one is an
error), dypho_slam.launch standalone:=true (no manager, each nodelet its own node) and
distributed.launch (which host runs what, ssh users, env-loader); and that every argument a user
can set (one with a default) in every file of launch/ has a doc string, so that
`roslaunch dypho_slam FILE --ros-args` explains it. Exit code 0 only when every check passed; each
failure is printed."""

import glob
import os
import shlex
import sys
import xml.etree.ElementTree as ET

import rospkg
import roslaunch.arg_dump
import roslaunch.config
from roslaunch.core import RLException

FAILURES = []


def check(condition, what):
    print(("ok:   " if condition else "FAIL: ") + what)
    if not condition:
        FAILURES.append(what)


def launch_dir():
    return os.path.join(rospkg.RosPack().get_path("dypho_slam"), "launch")


def load(launch, *args):
    """The ROSLaunchConfig of `launch` (a file of this package) with `args` (name:=value)."""
    path = os.path.join(launch_dir(), launch)
    saved = sys.argv
    sys.argv = [saved[0]] + list(args)  # roslaunch's loader reads the args from sys.argv
    try:
        return roslaunch.config.load_config_default([path], None, verbose=False, assign_machines=False)
    finally:
        sys.argv = saved


def nodes(config):
    return {n.namespace + n.name: n for n in config.nodes}


def remaps(node):
    return dict(node.remap_args)


LAYOUTS = {
    "realsense": ("/camera/color/image_raw", "/camera/aligned_depth_to_color/image_raw",
                  "/camera/color/camera_info"),
    "openni": ("/camera/rgb/image_rect_color", "/camera/depth_registered/image_raw",
               "/camera/rgb/camera_info"),
}


def check_live_camera():
    for camera, (rgb, depth, info) in LAYOUTS.items():
        n = nodes(load("live_camera.launch", "camera:=" + camera, "rviz:=false"))
        for name in ("/dypho/mask", "/dypho/tracking"):
            check(name in n, "live_camera camera:=%s starts %s" % (camera, name))
            if name in n:
                r = remaps(n[name])
                check((r.get("rgb/image"), r.get("depth/image"), r.get("rgb/camera_info")) == (rgb, depth, info),
                      "live_camera camera:=%s: %s reads %s, %s, %s (got %s)" % (camera, name, rgb, depth, info, r))
        check("/dypho/mapping" in n, "live_camera camera:=%s starts /dypho/mapping" % camera)
        check("/dypho_rviz" not in n, "live_camera rviz:=false starts no rviz")
    try:
        load("live_camera.launch", "camera:=kinect")
        check(False, "live_camera camera:=kinect is refused")
    except RLException as e:
        check("camera_must_be_realsense_or_openni" in str(e),
              "live_camera camera:=kinect is refused (%s)" % str(e).strip().splitlines()[-1])


def check_standalone():
    n = nodes(load("dypho_slam.launch"))
    check("/dypho/dypho_manager" in n, "dypho_slam.launch starts a manager by default")
    check(all(n[x].args.startswith("load ") for x in ("/dypho/mask", "/dypho/tracking", "/dypho/mapping")),
          "dypho_slam.launch loads the three nodelets into it")
    n = nodes(load("dypho_slam.launch", "standalone:=true"))
    check("/dypho/dypho_manager" not in n, "standalone:=true starts no manager")
    for name, cls in (("/dypho/mask", "DynamicMaskNodelet"), ("/dypho/tracking", "TrackingNodelet"),
                      ("/dypho/mapping", "GaussianMappingNodelet")):
        check(name in n and n[name].args.split() == ["standalone", "dypho_slam/" + cls],
              "standalone:=true runs %s as 'nodelet standalone dypho_slam/%s' (got %s)"
              % (name, cls, n[name].args if name in n else "no node"))
    config = load("dypho_slam.launch", "standalone:=true")
    check(not any(p.endswith("/num_worker_threads") for p in config.params),
          "standalone nodes get no num_worker_threads parameter (an unknown key to the nodelets)")


def check_distributed():
    config = load("distributed.launch", "camera_host:=cam.example", "mapping_host:=gpu.example",
                  "mapping_user:=slam", "camera:=openni")
    n = nodes(config)
    check(sorted(n) == ["/dypho/dypho_manager", "/dypho/mapping", "/dypho/mask", "/dypho/tracking"],
          "distributed.launch starts manager, mask, tracking, mapping (got %s)" % sorted(n))
    for name in ("/dypho/dypho_manager", "/dypho/mask", "/dypho/tracking"):
        check(name in n and n[name].machine_name == "dypho_camera_host", "%s runs on camera_host" % name)
    check(n["/dypho/mask"].args.split()[0] == "load" and n["/dypho/tracking"].args.split()[0] == "load",
          "mask and tracking share the manager on camera_host")
    check("/dypho/mapping" in n and n["/dypho/mapping"].machine_name == "dypho_mapping_host",
          "mapping runs on mapping_host")
    check(n["/dypho/mapping"].args.split() == ["standalone", "dypho_slam/GaussianMappingNodelet"],
          "mapping runs standalone (got %s)" % n["/dypho/mapping"].args)
    check(remaps(n["/dypho/tracking"]).get("rgb/image") == LAYOUTS["openni"][0],
          "distributed camera:=openni: tracking reads %s" % LAYOUTS["openni"][0])
    m = config.machines
    check(m["dypho_camera_host"].address == "cam.example" and m["dypho_camera_host"].user is None,
          "camera_host machine: address cam.example, no ssh user given")
    check(m["dypho_mapping_host"].address == "gpu.example" and m["dypho_mapping_host"].user == "slam",
          "mapping_host machine: address gpu.example, ssh user slam")
    loader = m["dypho_mapping_host"].env_loader
    check(loader.endswith("/scripts/env_loader.sh") and os.access(loader, os.X_OK),
          "env-loader defaults to this checkout's executable scripts/env_loader.sh (%s)" % loader)
    config = load("distributed.launch", "camera_file:=/calib/cam.yaml")
    n = nodes(config)
    check(sorted(n) == ["/dypho/dypho_manager", "/dypho/mapping", "/dypho/mask", "/dypho/tracking"],
          "distributed.launch with the defaults (both hosts localhost) resolves")
    for node in ("/dypho/mask", "/dypho/tracking"):
        check(params_of(config, node).get("camera_file") == "/calib/cam.yaml",
              "distributed camera_file:= reaches %s" % node)


def params_of(config, node):
    return {k[len(node) + 1:]: p.value for k, p in config.params.items() if k.startswith(node + "/")}


def check_tum_bag_camera():
    """tum_bag.launch gives TUM's published bags (nominal camera_info) their calibration file,
    chosen by the bag's name, and leaves other bags on their own camera_info."""
    cameras = os.path.join(rospkg.RosPack().get_path("dypho_slam"), "config", "cameras")
    cases = (("/data/freiburg2/rgbd_dataset_freiburg1_rpy.bag", os.path.join(cameras, "tum_fr1.yaml")),
             ("/data/rgbd_dataset_freiburg2_desk_with_person.bag", os.path.join(cameras, "tum_fr2.yaml")),
             ("/data/rgbd_dataset_freiburg3_walking_xyz.bag", os.path.join(cameras, "tum_fr3.yaml")),
             ("/data/freiburg1/bonn_crowd.bag", ""),
             ("/data/synthetic.bag", ""))
    for bag, expected in cases:
        config = load("tum_bag.launch", "bag:=" + bag)
        for node in ("/dypho/mask", "/dypho/tracking"):
            got = params_of(config, node).get("camera_file")
            check(got == expected, "tum_bag bag:=%s: %s camera_file is '%s' (got '%s')" % (bag, node, expected, got))
    config = load("tum_bag.launch", "bag:=/data/rgbd_dataset_freiburg1_rpy.bag", "camera_file:=/calib/mine.yaml")
    check(params_of(config, "/dypho/tracking").get("camera_file") == "/calib/mine.yaml",
          "tum_bag camera_file:= given by the user wins over the bag's name")
    config = load("tum_bag.launch", "bag:=/data/rgbd_dataset_freiburg1_rpy.bag", "camera_file:=none")
    check(params_of(config, "/dypho/tracking").get("camera_file") == "",
          "tum_bag camera_file:=none keeps the bag's camera_info")
    player = nodes(load("tum_bag.launch", "bag:=/data/b.bag", "end_delay:=4.5")).get("/player")
    prefix = shlex.split(player.launch_prefix or "") if player else []
    check(len(prefix) == 3 and prefix[0] == "bash" and os.path.isfile(prefix[1])
          and prefix[1].endswith("/scripts/play_then_wait.sh") and prefix[2] == "4.5",
          "tum_bag: the player runs through scripts/play_then_wait.sh with end_delay (got %s)" % prefix)
    for name in LAYOUTS:
        config = load("live_camera.launch", "camera:=" + name, "rviz:=false")
        check(params_of(config, "/dypho/tracking").get("camera_file") == "",
              "live_camera camera:=%s takes the driver's camera_info by default" % name)


def undocumented_args(xml_text):
    """Names of the <arg>s with a default (settable by a user) and no or an empty doc, in every
    branch of the file (args under if/unless that are not taken with the default values too)."""
    return [a.get("name") for a in ET.fromstring(xml_text).iter("arg")
            if a.get("default") is not None and not (a.get("doc") or "").strip()]


def check_arg_docs():
    # The check itself must be able to fail.
    check(undocumented_args('<launch><arg name="x" default="1"/><arg name="y" default="" doc=" "/>'
                            '<arg name="z" default="" doc="z"/><arg name="r"/><arg name="v" value="1"/></launch>')
          == ["x", "y"], "the doc check finds args with a default and no or a blank doc")
    files = sorted(glob.glob(os.path.join(launch_dir(), "*.launch")))
    check(len(files) >= 4, "launch/ holds the launch files (%d found)" % len(files))
    for path in files:
        name = os.path.basename(path)
        with open(path) as f:
            missing = undocumented_args(f.read())
        check(not missing, "%s: every arg with a default has a doc (missing: %s)" % (name, ", ".join(missing) or "none"))
        # What `roslaunch --ros-args` prints (args in force with the default values, includes not
        # followed): default None = required, '' = an empty default.
        saved = sys.argv
        sys.argv = [saved[0]]
        try:
            listed = roslaunch.arg_dump.get_args([path])
        finally:
            sys.argv = saved
        missing = sorted(n for n, (doc, default) in listed.items() if default is not None and not (doc or "").strip())
        check(not missing, "%s --ros-args: no optional arg 'undocumented' (missing: %s)" % (name, ", ".join(missing) or "none"))


def main():
    check_arg_docs()
    check_live_camera()
    check_standalone()
    check_distributed()
    check_tum_bag_camera()
    if FAILURES:
        print("%d launch-file check(s) failed" % len(FAILURES))
        return 1
    print("all launch-file checks passed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
