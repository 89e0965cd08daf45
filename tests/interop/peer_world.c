/* The interop peer's simulated world: see peer_world.h. */
#include "peer_world.h"

#include <stdint.h>

/* ---------------------------------------------------------------- geometry */

double wrap_angle(double a) {
  while (a > M_PI) a -= 2.0 * M_PI;
  while (a < -M_PI) a += 2.0 * M_PI;
  return a;
}

Pose2 compose(Pose2 a, Pose2 b) {
  const double c = cos(a.th), s = sin(a.th);
  Pose2 r = {a.x + c * b.x - s * b.y, a.y + s * b.x + c * b.y, wrap_angle(a.th + b.th)};
  return r;
}

Pose2 inverse(Pose2 a) {
  const double c = cos(a.th), s = sin(a.th);
  Pose2 r = {-c * a.x - s * a.y, s * a.x - c * a.y, wrap_angle(-a.th)};
  return r;
}

double yaw_of(double x, double y, double z, double w) {
  return atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z));
}

/* ---------------------------------------------------------------- the world */

/* A 10 m x 6 m room, a pillar inside the robot's loop and a wall stub, so that no two
 * places look alike. World frame; the robot's odom frame starts at kStart. */
const Wall kWalls[] = {
    {0.0, 0.0, 10.0, 0.0}, {10.0, 0.0, 10.0, 6.0}, {10.0, 6.0, 0.0, 6.0}, {0.0, 6.0, 0.0, 0.0},
    {4.4, 2.6, 5.6, 2.6},  {5.6, 2.6, 5.6, 3.4},   {5.6, 3.4, 4.4, 3.4},  {4.4, 3.4, 4.4, 2.6},
    {3.0, 6.0, 3.0, 5.2},  {8.6, 0.0, 8.6, 0.6},
};
const int kWallCount = (int)(sizeof(kWalls) / sizeof(kWalls[0]));
const Pose2 kStart = {2.0, 1.5, 0.0};
const Pose2 kLaserMount = {0.2, 0.0, 0.0}; /* base_link -> laser */
const double kLaserHeight = 0.3;

const double kAngleMin = -0.75 * M_PI; /* 270 degrees, 0.5 degree steps */
const double kRangeMin = 0.05, kRangeMax = 20.0;

double raycast(double ox, double oy, double angle) {
  const double dx = cos(angle), dy = sin(angle);
  double best = INFINITY;
  for (int i = 0; i < kWallCount; ++i) {
    const Wall* w = &kWalls[i];
    const double ex = w->x2 - w->x1, ey = w->y2 - w->y1;
    const double den = dx * ey - dy * ex;
    if (fabs(den) < 1e-12) continue;
    const double qx = w->x1 - ox, qy = w->y1 - oy;
    const double t = (qx * ey - qy * ex) / den; /* along the beam */
    const double u = (qx * dy - qy * dx) / den; /* along the wall */
    if (t > 0.0 && u >= 0.0 && u <= 1.0 && t < best) best = t;
  }
  return best;
}

/* Deterministic range noise (xorshift64*, Box-Muller). */
static uint64_t rng_state = 0x9E3779B97F4A7C15ull;
static double uniform01(void) {
  rng_state ^= rng_state >> 12;
  rng_state ^= rng_state << 25;
  rng_state ^= rng_state >> 27;
  return ((rng_state * 2685821657736338717ull) >> 11) * (1.0 / 9007199254740992.0);
}
double gaussian(double sigma) {
  const double u1 = uniform01() + 1e-300, u2 = uniform01();
  return sigma * sqrt(-2.0 * log(u1)) * cos(2.0 * M_PI * u2);
}

/* ---------------------------------------------------------------- the drive */

typedef struct {
  double distance; /* m forward, or 0 */
  double angle;    /* rad turned in place, or 0 */
} Leg;

static const double kSpeed = 0.5;      /* m/s */
static const double kTurnRate = 0.6;   /* rad/s */
static const double kStandStill = 1.0; /* s at the start and the end */
/* One lap of a 6 m x 3 m rectangle around the pillar, then half a side again (the loop
 * closes over ground already mapped). */
static const Leg kLegs[] = {
    {6.0, 0.0},      {0.0, M_PI / 2}, {3.0, 0.0},      {0.0, M_PI / 2}, {6.0, 0.0},
    {0.0, M_PI / 2}, {3.0, 0.0},      {0.0, M_PI / 2}, {3.0, 0.0},
};
static const int kLegCount = (int)(sizeof(kLegs) / sizeof(kLegs[0]));

static double leg_duration(const Leg* leg) {
  return leg->distance > 0.0 ? leg->distance / kSpeed : fabs(leg->angle) / kTurnRate;
}

double drive_duration(void) {
  double t = 2.0 * kStandStill;
  for (int i = 0; i < kLegCount; ++i) t += leg_duration(&kLegs[i]);
  return t;
}

/* The robot's pose in its odom frame (the start is the origin) and its velocities. */
Pose2 odom_pose_at(double t, double* v, double* w) {
  Pose2 p = {0.0, 0.0, 0.0};
  *v = 0.0;
  *w = 0.0;
  t -= kStandStill;
  if (t <= 0.0) return p;
  for (int i = 0; i < kLegCount; ++i) {
    const Leg* leg = &kLegs[i];
    const double d = leg_duration(leg);
    const double f = t < d ? t / d : 1.0;
    Pose2 step = {leg->distance * f, 0.0, leg->angle * f};
    p = compose(p, step);
    if (t < d) {
      *v = leg->distance > 0.0 ? kSpeed : 0.0;
      *w = leg->angle != 0.0 ? (leg->angle > 0 ? kTurnRate : -kTurnRate) : 0.0;
      return p;
    }
    t -= d;
  }
  return p;
}
