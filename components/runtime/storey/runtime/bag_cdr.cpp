#include "storey/runtime/bag_cdr.h"

namespace storey::runtime {

std::string rosTypeName(const std::string& dds_type_name) {
  std::string name = dds_type_name;
  const std::string dds = "::dds_::";
  if (const auto at = name.find(dds); at != std::string::npos) {
    name.replace(at, dds.size(), "::");
    if (!name.empty() && name.back() == '_') name.pop_back();
  }
  std::string out;
  for (std::size_t i = 0; i < name.size(); ++i) {
    if (name.compare(i, 2, "::") == 0) {
      out += '/';
      ++i;
    } else {
      out += name[i];
    }
  }
  return out;
}

std::string ddsTypeName(const std::string& ros_type_name) {
  const auto last = ros_type_name.rfind('/');
  if (last == std::string::npos) return ros_type_name;
  std::string prefix = ros_type_name.substr(0, last);
  std::string out;
  for (char c : prefix) {
    if (c == '/') {
      out += "::";
    } else {
      out += c;
    }
  }
  return out + "::dds_::" + ros_type_name.substr(last + 1) + "_";
}

}  // namespace storey::runtime
