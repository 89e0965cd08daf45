/* An independent DDS peer for storey: Eclipse Cyclone DDS (C API), standing in for a ROS 2
 * robot driver and a ROS 2 consumer on rmw_cyclonedds.
 *
 * Publishes, under ROS 2's DDS names and types (idlc's C types from storey's own IDL,
 * rewritten by ros2_idl_for_cyclone.cmake), a simulated robot that drives a loop in a
 * room (ranges ray cast against its walls, odometry exact):
 *   rt/robot1/scan  sensor_msgs/LaserScan  best effort, volatile, keep last 10 (a driver)
 *   rt/robot1/odom  nav_msgs/Odometry      reliable, volatile, keep last 10
 *   rt/tf_static    tf2_msgs/TFMessage     reliable, transient local, keep last 1
 *                                          (base_link -> laser)
 * and subscribes to storey's outputs:
 *   rt/tf                       building -> robot1/odom
 *   rt/robot1/pose              geometry_msgs/PoseStamped, frame "building"
 *   rt/robot1/floor             std_msgs/Int32
 *   rt/robot1/map               nav_msgs/OccupancyGrid, trinary
 *   rt/storey/building_markers  visualization_msgs/MarkerArray, frame "building"
 * (all reliable, transient local, keep last 1: storey's TopicKind::kLatest). It exits 0
 * when every check holds on the newest sample of each output, 1 when one fails by the
 * deadline, 2 when storey's endpoints are not discovered.
 *
 * Here: the endpoints, the drive's publishing loop and the wait for the checks.
 * peer_world.c is the simulated room, laser and drive; peer_outputs.c reads and checks
 * storey's outputs; peer_dds.c holds the DDS helpers.
 *
 *   storey_interop_peer [--domain 95] [--rate 4] [--match-timeout 30] [--output-timeout 30]
 */
#include <math.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "dds/dds.h"
#include "geometry_msgs/msg/PoseStamped.h"
#include "nav_msgs/msg/OccupancyGrid.h"
#include "nav_msgs/msg/Odometry.h"
#include "peer_dds.h"
#include "peer_outputs.h"
#include "peer_world.h"
#include "sensor_msgs/msg/LaserScan.h"
#include "std_msgs/msg/Int32.h"
#include "tf2_msgs/msg/TFMessage.h"
#include "visualization_msgs/msg/MarkerArray.h"

/* ---------------------------------------------------------------- time */

static double wall_now(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static builtin_interfaces_msg_dds__Time_ to_time(double stamp) {
  builtin_interfaces_msg_dds__Time_ t;
  const double s = floor(stamp);
  t.sec = (int32_t)s;
  t.nanosec = (uint32_t)llround((stamp - s) * 1e9);
  if (t.nanosec >= 1000000000u) {
    t.sec += 1;
    t.nanosec -= 1000000000u;
  }
  return t;
}

/* ---------------------------------------------------------------- main */

int main(int argc, char** argv) {
  int domain = 95;
  double rate = 4.0, match_timeout = 30.0, output_timeout = 30.0;
  for (int i = 1; i < argc; ++i) {
    const bool has_value = i + 1 < argc;
    if (!strcmp(argv[i], "--domain") && has_value)
      domain = atoi(argv[++i]);
    else if (!strcmp(argv[i], "--rate") && has_value)
      rate = atof(argv[++i]);
    else if (!strcmp(argv[i], "--match-timeout") && has_value)
      match_timeout = atof(argv[++i]);
    else if (!strcmp(argv[i], "--output-timeout") && has_value)
      output_timeout = atof(argv[++i]);
    else {
      fprintf(stderr,
              "usage: %s [--domain N] [--rate X] [--match-timeout S] [--output-timeout S]\n",
              argv[0]);
      return 2;
    }
  }
  if (!(rate > 0.0)) rate = 1.0;

  const dds_entity_t participant = dds_create_participant((dds_domainid_t)domain, NULL, NULL);
  if (participant < 0) die("dds_create_participant", participant);

  const dds_entity_t scan_writer = make_writer(participant, &sensor_msgs_msg_dds__LaserScan__desc,
                                               "rt/" ROBOT "/scan", false, false, 10);
  const dds_entity_t odom_writer = make_writer(participant, &nav_msgs_msg_dds__Odometry__desc,
                                               "rt/" ROBOT "/odom", true, false, 10);
  const dds_entity_t tf_static_writer =
      make_writer(participant, &tf2_msgs_msg_dds__TFMessage__desc, "rt/tf_static", true, true, 1);
  Readers readers;
  readers.tf = make_latest_reader(participant, &tf2_msgs_msg_dds__TFMessage__desc, "rt/tf");
  readers.pose = make_latest_reader(participant, &geometry_msgs_msg_dds__PoseStamped__desc,
                                    "rt/" ROBOT "/pose");
  readers.floor =
      make_latest_reader(participant, &std_msgs_msg_dds__Int32__desc, "rt/" ROBOT "/floor");
  readers.map =
      make_latest_reader(participant, &nav_msgs_msg_dds__OccupancyGrid__desc, "rt/" ROBOT "/map");
  readers.markers = make_latest_reader(participant, &visualization_msgs_msg_dds__MarkerArray__desc,
                                       "rt/storey/building_markers");

  /* storey's floor_mapper must read all three before the first scan goes out (scans are
   * best effort: one sent before the match is lost, as on a real robot). */
  const double t_start = wall_now();
  fprintf(stderr, "peer: domain %d, waiting for storey's readers of scan, odom and tf_static\n",
          domain);
  while (!(publication_matches(scan_writer) && publication_matches(odom_writer) &&
           publication_matches(tf_static_writer))) {
    if (wall_now() - t_start > match_timeout) {
      fprintf(stderr, "peer: FAIL: storey's readers not matched within %.0f s\n", match_timeout);
      report_endpoint("rt/" ROBOT "/scan", scan_writer, true);
      report_endpoint("rt/" ROBOT "/odom", odom_writer, true);
      report_endpoint("rt/tf_static", tf_static_writer, true);
      dds_delete(participant);
      return 2;
    }
    dds_sleepfor(DDS_MSECS(20));
  }
  fprintf(stderr, "peer: matched storey's readers after %.2f s\n", wall_now() - t_start);

  /* Sensor time: the wall clock now, as a driver stamps. */
  Recording rec;
  {
    struct timespec ts;
    clock_gettime(CLOCK_REALTIME, &ts);
    rec.stamp0 = (double)ts.tv_sec + 1e-3 * (double)(ts.tv_nsec / 1000000);
  }

  /* The laser's mounting, latched. */
  {
    tf2_msgs_msg_dds__TFMessage_ msg;
    memset(&msg, 0, sizeof msg);
    geometry_msgs_msg_dds__TransformStamped_ t;
    memset(&t, 0, sizeof t);
    t.header.stamp = to_time(rec.stamp0);
    t.header.frame_id = "base_link";
    t.child_frame_id = "laser";
    t.transform.translation.x = kLaserMount.x;
    t.transform.translation.y = kLaserMount.y;
    t.transform.translation.z = kLaserHeight;
    t.transform.rotation.z = sin(0.5 * kLaserMount.th);
    t.transform.rotation.w = cos(0.5 * kLaserMount.th);
    msg.transforms._length = msg.transforms._maximum = 1;
    msg.transforms._buffer = &t;
    msg.transforms._release = false;
    const dds_return_t rc = dds_write(tf_static_writer, &msg);
    if (rc < 0) die("write tf_static", rc);
  }

  /* The drive: odometry at 20 Hz, scans at 10 Hz (sensor time), sent `rate` times as fast
   * as real time. */
  Outputs out;
  memset(&out, 0, sizeof out);
  const double duration = drive_duration();
  const double dt = 0.05;
  const int steps = (int)floor(duration / dt + 1e-9);
  static float ranges[BEAMS];
  int scans_sent = 0, odom_sent = 0;
  rec.first_stamp = rec.stamp0;
  rec.last_stamp = rec.stamp0;
  const double t_drive = wall_now();
  fprintf(stderr, "peer: driving %.1f s of sensor time at %.1fx (%d scans)\n", duration, rate,
          steps / 2 + 1);
  for (int k = 0; k <= steps; ++k) {
    const double t = k * dt;
    const double due = t_drive + t / rate;
    double now;
    while ((now = wall_now()) < due) dds_sleepfor((dds_duration_t)((due - now) * 1e9) + 1);
    const double stamp = rec.stamp0 + t;
    double v, w;
    const Pose2 odom = odom_pose_at(t, &v, &w);

    nav_msgs_msg_dds__Odometry_ o;
    memset(&o, 0, sizeof o);
    o.header.stamp = to_time(stamp);
    o.header.frame_id = "odom";
    o.child_frame_id = "base_link";
    o.pose.pose.position.x = odom.x;
    o.pose.pose.position.y = odom.y;
    o.pose.pose.orientation.z = sin(0.5 * odom.th);
    o.pose.pose.orientation.w = cos(0.5 * odom.th);
    o.pose.covariance[0] = o.pose.covariance[7] = 1e-4;
    o.pose.covariance[35] = 1e-4;
    o.twist.twist.linear.x = v;
    o.twist.twist.angular.z = w;
    dds_return_t rc = dds_write(odom_writer, &o);
    if (rc < 0) die("write odom", rc);
    ++odom_sent;

    if (k % 2 == 0) {
      const Pose2 laser = compose(compose(kStart, odom), kLaserMount);
      const double increment = 1.5 * M_PI / (BEAMS - 1);
      for (int b = 0; b < BEAMS; ++b) {
        const double r =
            raycast(laser.x, laser.y, laser.th + kAngleMin + b * increment) + gaussian(0.01);
        ranges[b] = r < kRangeMax ? (float)r : INFINITY;
      }
      sensor_msgs_msg_dds__LaserScan_ s;
      memset(&s, 0, sizeof s);
      s.header.stamp = to_time(stamp);
      s.header.frame_id = "laser";
      s.angle_min = (float)kAngleMin;
      s.angle_max = (float)(kAngleMin + (BEAMS - 1) * increment);
      s.angle_increment = (float)increment;
      s.time_increment = 0.0f;
      s.scan_time = 0.1f;
      s.range_min = (float)kRangeMin;
      s.range_max = (float)kRangeMax;
      s.ranges._length = s.ranges._maximum = BEAMS;
      s.ranges._buffer = ranges;
      s.ranges._release = false;
      rc = dds_write(scan_writer, &s);
      if (rc < 0) die("write scan", rc);
      ++scans_sent;
      rec.last_stamp = stamp;
    }
    poll_outputs(&readers, &out);
  }
  fprintf(
      stderr,
      "peer: sent %d scans, %d odometry messages in %.2f s; %d poses, %d maps received so far\n",
      scans_sent, odom_sent, wall_now() - t_drive, out.pose_samples, out.map_samples);

  /* storey's outputs after the whole recording. */
  char why[2048];
  const double t_wait = wall_now();
  bool ok = false;
  while (true) {
    poll_outputs(&readers, &out);
    ok = check(&out, &rec, why, sizeof why);
    if (ok || wall_now() - t_wait > output_timeout) break;
    dds_sleepfor(DDS_MSECS(50));
  }

  printf("peer: /tf: %d samples; building -> " ODOM_FRAME " (%.4f, %.4f, %.5f rad)\n",
         out.tf_samples, out.building_odom.x, out.building_odom.y, out.building_odom.th);
  if (out.pose_samples) {
    double v, w;
    const Pose2 truth =
        compose(out.building_odom, odom_pose_at(out.pose_stamp - rec.stamp0, &v, &w));
    printf("peer: /" ROBOT
           "/pose: %d samples; (%.4f, %.4f, %.5f rad) in '%s' at t=%.2f s of %.2f; "
           "odometry there through /tf (%.4f, %.4f, %.5f)\n",
           out.pose_samples, out.pose.x, out.pose.y, out.pose.th, out.pose_frame,
           out.pose_stamp - rec.stamp0, rec.last_stamp - rec.stamp0, truth.x, truth.y, truth.th);
  } else {
    printf("peer: /" ROBOT "/pose: 0 samples\n");
  }
  printf("peer: /" ROBOT "/floor: %d samples; %d\n", out.floor_samples, out.floor);
  printf("peer: /" ROBOT
         "/map: %d samples; %u x %u at %.3f m in '%s', %u occupied, %u free, %u unknown, "
         "%u other; walls shown: %.0f %%\n",
         out.map_samples, out.map_width, out.map_height, out.map_resolution, out.map_frame,
         out.map_occupied, out.map_free, out.map_unknown, out.map_bad_values,
         out.map_samples && out.tf_found ? 100.0 * wall_coverage(&out) : 0.0);
  printf("peer: /storey/building_markers: %d samples; %u markers, %u added, %u points\n",
         out.marker_samples, out.markers, out.marker_adds, out.marker_points);
  if (!ok) {
    printf("peer: FAIL after %.0f s: %s\n", output_timeout, why);
    report_endpoint("rt/" ROBOT "/scan", scan_writer, true);
    report_endpoint("rt/" ROBOT "/odom", odom_writer, true);
    report_endpoint("rt/tf_static", tf_static_writer, true);
    report_endpoint("rt/tf", readers.tf, false);
    report_endpoint("rt/" ROBOT "/pose", readers.pose, false);
    report_endpoint("rt/" ROBOT "/floor", readers.floor, false);
    report_endpoint("rt/" ROBOT "/map", readers.map, false);
    report_endpoint("rt/storey/building_markers", readers.markers, false);
  } else {
    printf(
        "peer: PASS: storey mapped the Cyclone DDS robot; every output checked (%.1f s after the "
        "drive)\n",
        wall_now() - t_wait);
  }
  free(out.map_data);
  dds_delete(participant);
  return ok ? 0 : 1;
}
