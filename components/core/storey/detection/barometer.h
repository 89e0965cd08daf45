// Barometric height: the hypsometric equation for a dry, isothermal air layer. Only
// differences of these heights mean anything (the reference pressure is arbitrary).
#pragma once

namespace storey::detection {

constexpr double kGasConstantDryAir = 287.05;  // J/(kg K)
constexpr double kStandardGravity = 9.80665;   // m/s^2
constexpr double kReferencePressure = 101325.0;

// Scale height R T / g in metres for a layer at `temperature_kelvin`.
double scaleHeight(double temperature_kelvin);
// Height above the level where the pressure is `reference_pascal`.
double pressureHeight(double pascal, double temperature_kelvin,
                      double reference_pascal = kReferencePressure);
// Height of the level at `to_pascal` above the level at `from_pascal`.
double heightDifference(double from_pascal, double to_pascal, double temperature_kelvin);
// Pressure at `height` above the level at `reference_pascal` (inverse of pressureHeight).
double pressureAtHeight(double height, double temperature_kelvin,
                        double reference_pascal = kReferencePressure);

}  // namespace storey::detection
