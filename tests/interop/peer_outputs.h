/* What storey sends the interop peer (peer_outputs.c): the newest sample of each output,
 * taken from the peer's readers, and the checks on them. */
#ifndef STOREY_INTEROP_PEER_OUTPUTS_H
#define STOREY_INTEROP_PEER_OUTPUTS_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "dds/dds.h"
#include "peer_world.h"

typedef struct {
  /* /tf: building -> robot1/odom */
  int tf_samples;
  bool tf_found;
  char tf_problem[160];
  Pose2 building_odom;
  double tf_z, tf_stamp;
  /* /robot1/pose */
  int pose_samples;
  char pose_frame[64];
  Pose2 pose;
  double pose_z, pose_stamp, pose_qx, pose_qy, pose_qnorm;
  /* /robot1/floor */
  int floor_samples;
  int32_t floor;
  /* /robot1/map */
  int map_samples;
  char map_frame[64];
  uint32_t map_width, map_height;
  float map_resolution;
  double map_origin_x, map_origin_y, map_origin_yaw;
  uint32_t map_length;
  int8_t* map_data;
  uint32_t map_bad_values, map_occupied, map_free, map_unknown;
  /* /storey/building_markers */
  int marker_samples;
  uint32_t markers, marker_adds, marker_points, marker_bad_frames;
  char marker_bad_frame[64];
} Outputs;

/* The peer's readers of storey's outputs (make_latest_reader). */
typedef struct {
  dds_entity_t tf, pose, floor, map, markers;
} Readers;

/* Takes every new sample of each output into `out`; the newest one wins. */
void poll_outputs(const Readers* r, Outputs* out);

typedef struct {
  double first_stamp, last_stamp; /* the scans sent */
  double stamp0;                  /* sensor time of t = 0 */
} Recording;

/* The fraction of the room's walls the map shows as occupied (see peer_outputs.c). */
double wall_coverage(const Outputs* out);

/* Every check on the newest sample of each output, once the whole recording was sent;
 * false with the failures, "; "-separated, in `why`. */
bool check(const Outputs* out, const Recording* rec, char* why, size_t size);

#endif
