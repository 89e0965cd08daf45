/* The interop peer's simulated world (peer_world.c): 2D pose geometry, the room and the
 * laser ray cast against its walls, the drive and its exact odometry, and deterministic
 * range noise. No DDS here: cyclone_peer.c publishes it, peer_outputs.c checks storey's
 * outputs against it. */
#ifndef STOREY_INTEROP_PEER_WORLD_H
#define STOREY_INTEROP_PEER_WORLD_H

#include <math.h>

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

#define ROBOT "robot1"
#define ODOM_FRAME ROBOT "/odom" /* storey's name for the robot's odom frame in /tf */

/* ---------------------------------------------------------------- geometry */

typedef struct {
  double x, y, th;
} Pose2;

double wrap_angle(double a);
Pose2 compose(Pose2 a, Pose2 b);
Pose2 inverse(Pose2 a);
double yaw_of(double x, double y, double z, double w);

/* ---------------------------------------------------------------- the world */

typedef struct {
  double x1, y1, x2, y2;
} Wall;

/* The room's walls in the world frame; the robot's odom frame starts at kStart. */
extern const Wall kWalls[];
extern const int kWallCount;
extern const Pose2 kStart;
extern const Pose2 kLaserMount; /* base_link -> laser */
extern const double kLaserHeight;

#define BEAMS 541
extern const double kAngleMin; /* 270 degrees, 0.5 degree steps */
extern const double kRangeMin, kRangeMax;

/* The distance from (ox, oy) along `angle` to the nearest wall, INFINITY if none. */
double raycast(double ox, double oy, double angle);

/* Deterministic range noise: a zero-mean Gaussian sample, the same sequence every run. */
double gaussian(double sigma);

/* ---------------------------------------------------------------- the drive */

/* The drive's length in seconds of sensor time, stand-stills included. */
double drive_duration(void);

/* The robot's pose in its odom frame (the start is the origin) and its velocities. */
Pose2 odom_pose_at(double t, double* v, double* w);

#endif
