#include "storey/detection/barometer.h"

#include <cmath>

namespace storey::detection {

double scaleHeight(double temperature_kelvin) {
  return kGasConstantDryAir * temperature_kelvin / kStandardGravity;
}

double pressureHeight(double pascal, double temperature_kelvin, double reference_pascal) {
  return scaleHeight(temperature_kelvin) * std::log(reference_pascal / pascal);
}

double heightDifference(double from_pascal, double to_pascal, double temperature_kelvin) {
  return scaleHeight(temperature_kelvin) * std::log(from_pascal / to_pascal);
}

double pressureAtHeight(double height, double temperature_kelvin, double reference_pascal) {
  return reference_pascal * std::exp(-height / scaleHeight(temperature_kelvin));
}

}  // namespace storey::detection
