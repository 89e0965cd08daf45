// CDR (de)serialization of generated message types for bags: the bytes ROS 2 stores in a
// rosbag2 bag and sends on the wire, a 4-byte encapsulation header (CDR little endian on
// this platform) followed by the payload. Generic over any fastddsgen-generated type.
#pragma once

#include <fastcdr/Cdr.h>
#include <fastcdr/FastBuffer.h>
#include <fastcdr/exceptions/Exception.h>

#include <cstdint>
#include <new>
#include <stdexcept>
#include <string>
#include <vector>

namespace storey::runtime {

// Bytes that do not decode as the expected type (truncated, wrong type, bad header).
class CdrError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

template <typename T>
void serializeCdrInto(const T& message, std::vector<std::uint8_t>& bytes) {
  bytes.resize(T::getCdrSerializedSize(message) + 4);
  eprosima::fastcdr::FastBuffer buffer(reinterpret_cast<char*>(bytes.data()), bytes.size());
  eprosima::fastcdr::Cdr cdr(buffer, eprosima::fastcdr::Cdr::DEFAULT_ENDIAN,
                             eprosima::fastcdr::Cdr::DDS_CDR);
  try {
    cdr.serialize_encapsulation();
    message.serialize(cdr);
  } catch (const eprosima::fastcdr::exception::Exception& e) {
    throw CdrError(std::string("cannot serialize a message: ") + e.what());
  }
  bytes.resize(cdr.getSerializedDataLength());
}

template <typename T>
std::vector<std::uint8_t> serializeCdr(const T& message) {
  std::vector<std::uint8_t> bytes;
  serializeCdrInto(message, bytes);
  return bytes;
}

// Throws CdrError naming `what` (e.g. the type) when the bytes do not decode.
template <typename T>
void deserializeCdr(const std::uint8_t* data, std::size_t size, T& message,
                    const std::string& what = "message") {
  if (size < 4) {
    throw CdrError("cannot decode " + what + ": " + std::to_string(size) +
                   " bytes is shorter than the CDR encapsulation header");
  }
  // Fast CDR only reads through this pointer when deserializing.
  eprosima::fastcdr::FastBuffer buffer(const_cast<char*>(reinterpret_cast<const char*>(data)),
                                       size);
  eprosima::fastcdr::Cdr cdr(buffer, eprosima::fastcdr::Cdr::DEFAULT_ENDIAN,
                             eprosima::fastcdr::Cdr::DDS_CDR);
  try {
    cdr.read_encapsulation();
    message.deserialize(cdr);
  } catch (const eprosima::fastcdr::exception::Exception& e) {
    throw CdrError("cannot decode " + what + " from " + std::to_string(size) +
                   " bytes (truncated or another type?): " + e.what());
  } catch (const std::bad_alloc&) {
    throw CdrError("cannot decode " + what + ": a length field is absurd");
  }
}

template <typename T>
T deserializeCdr(const std::vector<std::uint8_t>& bytes, const std::string& what = "message") {
  T message;
  deserializeCdr(bytes.data(), bytes.size(), message, what);
  return message;
}

// "sensor_msgs::msg::dds_::LaserScan_" <-> "sensor_msgs/msg/LaserScan" (ROS 2 naming).
std::string rosTypeName(const std::string& dds_type_name);
std::string ddsTypeName(const std::string& ros_type_name);

}  // namespace storey::runtime
