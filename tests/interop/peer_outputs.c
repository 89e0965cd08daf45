/* What storey sends the interop peer, and the checks on it: see peer_outputs.h. */
#include "peer_outputs.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "geometry_msgs/msg/PoseStamped.h"
#include "nav_msgs/msg/OccupancyGrid.h"
#include "peer_dds.h"
#include "std_msgs/msg/Int32.h"
#include "tf2_msgs/msg/TFMessage.h"
#include "visualization_msgs/msg/MarkerArray.h"

/* ---------------------------------------------------------------- what storey sends */

/* A ROS 2 stamp in seconds. */
static double from_time(builtin_interfaces_msg_dds__Time_ t) {
  return (double)t.sec + 1e-9 * (double)t.nanosec;
}

static void copy_string(char* dst, size_t size, const char* src) {
  snprintf(dst, size, "%s", src ? src : "(null)");
}

#define MAX_TAKE 16

static void take_tf(dds_entity_t reader, Outputs* out) {
  void* samples[MAX_TAKE] = {NULL};
  dds_sample_info_t infos[MAX_TAKE];
  const int n = dds_take(reader, samples, infos, MAX_TAKE, MAX_TAKE);
  for (int i = 0; i < n; ++i) {
    if (!infos[i].valid_data) continue;
    const tf2_msgs_msg_dds__TFMessage_* m = samples[i];
    ++out->tf_samples;
    out->tf_found = false;
    snprintf(out->tf_problem, sizeof out->tf_problem, "%u transforms, none building -> " ODOM_FRAME,
             m->transforms._length);
    for (uint32_t k = 0; k < m->transforms._length; ++k) {
      const geometry_msgs_msg_dds__TransformStamped_* t = &m->transforms._buffer[k];
      if (strcmp(t->child_frame_id, ODOM_FRAME) != 0) continue;
      if (strcmp(t->header.frame_id, "building") != 0) {
        snprintf(out->tf_problem, sizeof out->tf_problem,
                 "%s's parent frame is '%s', not 'building'", ODOM_FRAME, t->header.frame_id);
        continue;
      }
      const geometry_msgs_msg_dds__Quaternion_* q = &t->transform.rotation;
      out->building_odom.x = t->transform.translation.x;
      out->building_odom.y = t->transform.translation.y;
      out->building_odom.th = yaw_of(q->x, q->y, q->z, q->w);
      out->tf_z = t->transform.translation.z;
      out->tf_stamp = from_time(t->header.stamp);
      out->tf_found = true;
      out->tf_problem[0] = '\0';
    }
  }
  if (n > 0) dds_return_loan(reader, samples, n);
}

static void take_pose(dds_entity_t reader, Outputs* out) {
  void* samples[MAX_TAKE] = {NULL};
  dds_sample_info_t infos[MAX_TAKE];
  const int n = dds_take(reader, samples, infos, MAX_TAKE, MAX_TAKE);
  for (int i = 0; i < n; ++i) {
    if (!infos[i].valid_data) continue;
    const geometry_msgs_msg_dds__PoseStamped_* m = samples[i];
    const geometry_msgs_msg_dds__Quaternion_* q = &m->pose.orientation;
    ++out->pose_samples;
    copy_string(out->pose_frame, sizeof out->pose_frame, m->header.frame_id);
    out->pose.x = m->pose.position.x;
    out->pose.y = m->pose.position.y;
    out->pose.th = yaw_of(q->x, q->y, q->z, q->w);
    out->pose_z = m->pose.position.z;
    out->pose_qx = q->x;
    out->pose_qy = q->y;
    out->pose_qnorm = sqrt(q->x * q->x + q->y * q->y + q->z * q->z + q->w * q->w);
    out->pose_stamp = from_time(m->header.stamp);
  }
  if (n > 0) dds_return_loan(reader, samples, n);
}

static void take_floor(dds_entity_t reader, Outputs* out) {
  void* samples[MAX_TAKE] = {NULL};
  dds_sample_info_t infos[MAX_TAKE];
  const int n = dds_take(reader, samples, infos, MAX_TAKE, MAX_TAKE);
  for (int i = 0; i < n; ++i) {
    if (!infos[i].valid_data) continue;
    ++out->floor_samples;
    out->floor = ((const std_msgs_msg_dds__Int32_*)samples[i])->data;
  }
  if (n > 0) dds_return_loan(reader, samples, n);
}

static void take_map(dds_entity_t reader, Outputs* out) {
  void* samples[MAX_TAKE] = {NULL};
  dds_sample_info_t infos[MAX_TAKE];
  const int n = dds_take(reader, samples, infos, MAX_TAKE, MAX_TAKE);
  for (int i = 0; i < n; ++i) {
    if (!infos[i].valid_data) continue;
    const nav_msgs_msg_dds__OccupancyGrid_* m = samples[i];
    const geometry_msgs_msg_dds__Quaternion_* q = &m->info.origin.orientation;
    ++out->map_samples;
    copy_string(out->map_frame, sizeof out->map_frame, m->header.frame_id);
    out->map_width = m->info.width;
    out->map_height = m->info.height;
    out->map_resolution = m->info.resolution;
    out->map_origin_x = m->info.origin.position.x;
    out->map_origin_y = m->info.origin.position.y;
    out->map_origin_yaw = yaw_of(q->x, q->y, q->z, q->w);
    out->map_length = m->data._length;
    free(out->map_data);
    out->map_data = malloc(m->data._length ? m->data._length : 1);
    if (!out->map_data) die("map copy", DDS_RETCODE_OUT_OF_RESOURCES);
    memcpy(out->map_data, m->data._buffer, m->data._length);
    out->map_bad_values = out->map_occupied = out->map_free = out->map_unknown = 0;
    for (uint32_t k = 0; k < m->data._length; ++k) {
      const int8_t v = m->data._buffer[k];
      if (v == 100)
        ++out->map_occupied;
      else if (v == 0)
        ++out->map_free;
      else if (v == -1)
        ++out->map_unknown;
      else
        ++out->map_bad_values;
    }
  }
  if (n > 0) dds_return_loan(reader, samples, n);
}

static void take_markers(dds_entity_t reader, Outputs* out) {
  void* samples[MAX_TAKE] = {NULL};
  dds_sample_info_t infos[MAX_TAKE];
  const int n = dds_take(reader, samples, infos, MAX_TAKE, MAX_TAKE);
  for (int i = 0; i < n; ++i) {
    if (!infos[i].valid_data) continue;
    const visualization_msgs_msg_dds__MarkerArray_* m = samples[i];
    ++out->marker_samples;
    out->markers = m->markers._length;
    out->marker_adds = out->marker_points = out->marker_bad_frames = 0;
    for (uint32_t k = 0; k < m->markers._length; ++k) {
      const visualization_msgs_msg_dds__Marker_* marker = &m->markers._buffer[k];
      if (strcmp(marker->header.frame_id, "building") != 0) {
        ++out->marker_bad_frames;
        copy_string(out->marker_bad_frame, sizeof out->marker_bad_frame, marker->header.frame_id);
      }
      if (marker->action == visualization_msgs_msg_dds__Marker_Constants_ADD) {
        ++out->marker_adds;
        out->marker_points += marker->points._length;
      }
    }
  }
  if (n > 0) dds_return_loan(reader, samples, n);
}

void poll_outputs(const Readers* r, Outputs* out) {
  take_tf(r->tf, out);
  take_pose(r->pose, out);
  take_floor(r->floor, out);
  take_map(r->map, out);
  take_markers(r->markers, out);
}

/* ---------------------------------------------------------------- checks */

/* The fraction of points sampled every 0.25 m along the room's walls (as the laser saw
 * them: the world in the robot's odom frame, through storey's building -> odom) that
 * have an occupied cell within 2 cells in the map. */
double wall_coverage(const Outputs* out) {
  const Pose2 odom_world = inverse(kStart);
  int samples = 0, hits = 0;
  const double res = out->map_resolution;
  for (int i = 0; i < kWallCount; ++i) {
    const Wall* w = &kWalls[i];
    const double len = hypot(w->x2 - w->x1, w->y2 - w->y1);
    for (double s = 0.125; s < len; s += 0.25) {
      const double f = s / len;
      Pose2 world = {w->x1 + f * (w->x2 - w->x1), w->y1 + f * (w->y2 - w->y1), 0.0};
      const Pose2 building = compose(out->building_odom, compose(odom_world, world));
      /* Into the grid (its origin's yaw is checked to be 0). */
      const int cx = (int)floor((building.x - out->map_origin_x) / res);
      const int cy = (int)floor((building.y - out->map_origin_y) / res);
      ++samples;
      bool hit = false;
      for (int dy = -2; dy <= 2 && !hit; ++dy)
        for (int dx = -2; dx <= 2 && !hit; ++dx) {
          const int x = cx + dx, y = cy + dy;
          if (x < 0 || y < 0 || x >= (int)out->map_width || y >= (int)out->map_height) continue;
          hit = out->map_data[(size_t)y * out->map_width + (size_t)x] == 100;
        }
      if (hit) ++hits;
    }
  }
  return samples ? (double)hits / samples : 0.0;
}

/* Appends a failure to `why`; returns false. */
static bool fail(char* why, size_t size, const char* fmt, ...)
    __attribute__((format(printf, 3, 4)));
static bool fail(char* why, size_t size, const char* fmt, ...) {
  const size_t used = strlen(why);
  if (used + 3 >= size) return false;
  if (used) strcat(why, "; ");
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(why + strlen(why), size - strlen(why), fmt, ap);
  va_end(ap);
  return false;
}

/* Every check on the newest sample of each output, once the whole recording was sent. */
bool check(const Outputs* out, const Recording* rec, char* why, size_t size) {
  bool ok = true;
  why[0] = '\0';
  if (!out->tf_samples)
    ok = fail(why, size, "no /tf");
  else if (!out->tf_found)
    ok = fail(why, size, "/tf: %s", out->tf_problem);
  else if (fabs(out->tf_z) > 1e-6)
    ok = fail(why, size, "/tf: building -> " ODOM_FRAME " z %.3f, not 0", out->tf_z);

  if (!out->pose_samples)
    ok = fail(why, size, "no /" ROBOT "/pose");
  else {
    if (strcmp(out->pose_frame, "building") != 0)
      ok = fail(why, size, "/" ROBOT "/pose frame '%s', not 'building'", out->pose_frame);
    if (fabs(out->pose_qnorm - 1.0) > 1e-6 || fabs(out->pose_qx) > 1e-9 ||
        fabs(out->pose_qy) > 1e-9)
      ok = fail(why, size, "/" ROBOT "/pose orientation is not a unit yaw quaternion");
    if (fabs(out->pose_z) > 1e-6)
      ok = fail(why, size, "/" ROBOT "/pose z %.3f, not floor 0's 0", out->pose_z);
    if (out->pose_stamp < rec->first_stamp - 1e-6 || out->pose_stamp > rec->last_stamp + 1e-6)
      ok = fail(why, size, "/" ROBOT "/pose stamp %.3f outside the recording [%.3f, %.3f]",
                out->pose_stamp, rec->first_stamp, rec->last_stamp);
    else if (out->pose_stamp < rec->last_stamp - 3.0)
      ok = fail(why, size, "/" ROBOT "/pose is %.1f s before the recording's end",
                rec->last_stamp - out->pose_stamp);
    if (out->tf_found) {
      /* The pose is the robot's newest node; /tf puts its odometry there. */
      double v, w;
      const Pose2 odom = odom_pose_at(out->pose_stamp - rec->stamp0, &v, &w);
      const Pose2 via_tf = compose(out->building_odom, odom);
      const double d = hypot(via_tf.x - out->pose.x, via_tf.y - out->pose.y);
      const double a = fabs(wrap_angle(via_tf.th - out->pose.th));
      if (fabs(out->tf_stamp - out->pose_stamp) > 1e-6)
        ok = fail(why, size, "/tf (t=%.3f) and /" ROBOT "/pose (t=%.3f) of different nodes",
                  out->tf_stamp - rec->stamp0, out->pose_stamp - rec->stamp0);
      else if (d > 0.01 || a > 0.005)
        ok = fail(why, size,
                  "/tf composed with the odometry misses /" ROBOT "/pose by %.3f m / %.4f rad", d,
                  a);
      /* Exact odometry, a static world: SLAM keeps the odom frame where it is. */
      const double drift = hypot(out->building_odom.x, out->building_odom.y);
      if (drift > 0.15 || fabs(out->building_odom.th) > 0.03)
        ok = fail(why, size,
                  "building -> " ODOM_FRAME " is (%.3f, %.3f, %.4f), expected near identity",
                  out->building_odom.x, out->building_odom.y, out->building_odom.th);
    }
  }

  if (!out->floor_samples)
    ok = fail(why, size, "no /" ROBOT "/floor");
  else if (out->floor != 0)
    ok = fail(why, size, "/" ROBOT "/floor %d, not 0", out->floor);

  if (!out->map_samples)
    ok = fail(why, size, "no /" ROBOT "/map");
  else {
    if (strcmp(out->map_frame, "building") != 0)
      ok = fail(why, size, "/" ROBOT "/map frame '%s', not 'building'", out->map_frame);
    if (out->map_width == 0 || out->map_height == 0 ||
        (uint64_t)out->map_width * out->map_height != out->map_length)
      ok = fail(why, size, "/" ROBOT "/map is %u x %u with %u cells", out->map_width,
                out->map_height, out->map_length);
    if (out->map_bad_values)
      ok = fail(why, size, "/" ROBOT "/map has %u cells not 0, 100 or -1", out->map_bad_values);
    if (!(out->map_resolution > 0.0f))
      ok = fail(why, size, "/" ROBOT "/map resolution %g", out->map_resolution);
    if (fabs(out->map_origin_yaw) > 1e-9) ok = fail(why, size, "/" ROBOT "/map origin turned");
    if (!out->map_occupied || !out->map_free)
      ok = fail(why, size, "/" ROBOT "/map has no occupied or no free cell");
    if (out->tf_found && ok) {
      const double coverage = wall_coverage(out);
      if (coverage < 0.9)
        ok = fail(why, size, "/" ROBOT "/map shows %.0f %% of the room's walls", 100.0 * coverage);
    }
  }

  if (!out->marker_samples)
    ok = fail(why, size, "no /storey/building_markers");
  else {
    if (out->markers == 0 || out->marker_adds == 0 || out->marker_points == 0)
      ok = fail(why, size, "/storey/building_markers: %u markers, %u added, %u points",
                out->markers, out->marker_adds, out->marker_points);
    if (out->marker_bad_frames)
      ok = fail(why, size, "/storey/building_markers: %u markers in frame '%s', not 'building'",
                out->marker_bad_frames, out->marker_bad_frame);
  }
  return ok;
}
