// Uses the installed storey::geometry and storey::bag: composes poses, writes a bag of
// them and reads it back. Exit status 0 only when everything matches.
#include <cmath>
#include <cstring>
#include <iostream>

#include "storey/bag/bag_reader.h"
#include "storey/bag/bag_writer.h"
#include "storey/geometry/pose2.h"

int main(int argc, char** argv) {
  if (argc != 2) {
    std::cerr << "usage: storey_consumer BAG_FOLDER\n";
    return 2;
  }
  const storey::geometry::Pose2 step(1.0, 0.0, 0.5);
  storey::geometry::Pose2 pose;
  {
    storey::bag::BagWriter writer(argv[1]);
    writer.createTopic({"/poses", "storey_consumer/msg/Pose2", "cdr", ""});
    for (int i = 0; i < 4; ++i) {
      pose = pose * step;
      const double xyt[3] = {pose.x(), pose.y(), pose.theta()};
      writer.write("/poses", i * 1000, reinterpret_cast<const std::uint8_t*>(xyt), sizeof(xyt));
    }
  }
  storey::bag::BagReader reader(argv[1]);
  storey::bag::BagMessage message;
  storey::geometry::Pose2 last;
  int count = 0;
  while (reader.next(message)) {
    double xyt[3];
    if (message.data.size() != sizeof(xyt)) return 1;
    std::memcpy(xyt, message.data.data(), sizeof(xyt));
    last = storey::geometry::Pose2(xyt[0], xyt[1], xyt[2]);
    ++count;
  }
  const bool ok = count == 4 && std::abs(last.x() - pose.x()) < 1e-12 &&
                  std::abs(last.theta() - pose.theta()) < 1e-12;
  std::cout << "consumer: " << count << " poses read back, last (" << last.x() << ", " << last.y()
            << ", " << last.theta() << ") " << (ok ? "ok" : "MISMATCH") << "\n";
  return ok ? 0 : 1;
}
