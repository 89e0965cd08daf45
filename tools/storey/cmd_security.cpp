// `storey security`: makes the DDS Security folder (CA, identities, signed governance and
// permissions) a secured deployment uses; see docs/security.md.
#include <iostream>
#include <map>
#include <set>
#include <sstream>

#include "args.h"
#include "storey/catalog/all_components.h"
#include "storey/runtime/bringup.h"
#include "storey/runtime/security.h"

namespace storey::cli {

extern const char* const summary_security =
    "make DDS Security artifacts (CA, identities, signed permissions)";

namespace {

std::vector<std::string> splitList(const std::string& text, char separator) {
  std::vector<std::string> out;
  std::stringstream stream(text);
  std::string item;
  while (std::getline(stream, item, separator)) {
    if (!item.empty()) out.push_back(item);
  }
  return out;
}

// "talker=pub:rt/chatter,sub:rt/a;listener=sub:rt/chatter" → grants by participant.
std::map<std::string, runtime::TopicGrant> parseGrants(const std::string& text) {
  std::map<std::string, runtime::TopicGrant> grants;
  for (const std::string& entry : splitList(text, ';')) {
    const auto eq = entry.find('=');
    if (eq == std::string::npos || eq == 0) {
      throw UsageError("--grant entry '" + entry + "' is not NAME=pub:TOPIC,sub:TOPIC,...");
    }
    runtime::TopicGrant grant;
    grant.participant = entry.substr(0, eq);
    for (const std::string& rule : splitList(entry.substr(eq + 1), ',')) {
      if (rule.rfind("pub:", 0) == 0 && rule.size() > 4) {
        grant.publish.push_back(rule.substr(4));
      } else if (rule.rfind("sub:", 0) == 0 && rule.size() > 4) {
        grant.subscribe.push_back(rule.substr(4));
      } else {
        throw UsageError("--grant rule '" + rule + "' for " + grant.participant +
                         " is not pub:TOPIC or sub:TOPIC");
      }
    }
    grants[grant.participant] = grant;
  }
  return grants;
}

}  // namespace

int run_security(Args& args) {
  args.usage(
          "init --output DIR [--participants a,b] [--bringup FILE] [--grant SPEC]\n"
          "       storey security add --output DIR --participants a,b [--grant SPEC]",
          "init: creates DIR with an ECDSA prime256v1 CA, a signed governance (join access\n"
          "control, encryption) and, per participant, a key, a certificate and signed\n"
          "permissions (default DENY). add: new participants in an existing DIR.\n"
          "Participants: --participants, plus every process of --bringup FILE (its process\n"
          "names are the participant names `storey launch` uses). Each participant may\n"
          "publish and subscribe --topics unless --grant lists its topics explicitly,\n"
          "e.g. --grant 'talker=pub:rt/chatter;listener=sub:rt/chatter' (fnmatch patterns,\n"
          "DDS names: rt/<ROS 2 name>). Secure a run with STOREY_SECURITY_DIR=DIR.")
      .option("output", "DIR", "security folder")
      .option("participants", "LIST", "comma-separated participant names")
      .option("bringup", "FILE", "add every process of this bringup file as a participant")
      .option("topics", "LIST", "topics for participants without a --grant", "rt/*")
      .option("grant", "SPEC", "explicit per-participant topics (see above)")
      .option("domains", "MIN-MAX", "DDS domain ids the grants cover", "0-232")
      .option("days", "N", "validity of certificates and permissions", "3650");
  if (!args.parse()) return 0;
  const std::string action = args.positional(0, "action (init or add)");
  if (action != "init" && action != "add") {
    throw UsageError("unknown action '" + action + "' (init or add)");
  }
  if (!args.has("output")) throw UsageError("--output DIR is required");

  std::vector<std::string> participants = splitList(args.get("participants"), ',');
  if (args.has("bringup")) {
    runtime::ComponentRegistry registry;
    catalog::registerStoreyComponents(registry);
    for (const auto& process : runtime::readBringup(args.get("bringup"), registry).processes) {
      participants.push_back(process.name);
    }
  }
  auto grants = parseGrants(args.get("grant"));
  for (const auto& [name, grant] : grants) participants.push_back(name);
  std::set<std::string> seen;
  runtime::SecurityInitOptions options;
  options.output_dir = args.get("output");
  options.validity_days = static_cast<int>(args.getInt("days"));
  if (options.validity_days < 1) throw UsageError("--days must be at least 1");
  const auto range = splitList(args.get("domains"), '-');
  if (range.size() != 2) throw UsageError("--domains must be MIN-MAX, e.g. 0-232");
  try {
    options.domain_min = std::stoi(range[0]);
    options.domain_max = std::stoi(range[1]);
  } catch (const std::exception&) {
    throw UsageError("--domains must be MIN-MAX, e.g. 0-232");
  }
  const std::vector<std::string> topics = splitList(args.get("topics"), ',');
  for (const std::string& name : participants) {
    if (!seen.insert(name).second) continue;
    auto it = grants.find(name);
    if (it != grants.end()) {
      options.grants.push_back(it->second);
    } else {
      options.grants.push_back({name, topics, topics});
    }
  }
  if (action == "init") {
    runtime::initSecurityFolder(options);
  } else {
    if (options.grants.empty()) throw UsageError("add needs --participants or --grant");
    for (const auto& grant : options.grants) {
      runtime::addSecurityParticipant(options.output_dir, grant, options);
    }
  }
  for (const auto& grant : options.grants) {
    std::cout << grant.participant << ": " << options.output_dir << "/" << grant.participant
              << "/ (publish " << grant.publish.size() << ", subscribe " << grant.subscribe.size()
              << " topic rules)\n";
  }
  std::cout << "security folder " << options.output_dir
            << (action == "init" ? " created" : " updated")
            << "; run with STOREY_SECURITY_DIR=" << options.output_dir << "\n";
  return 0;
}

}  // namespace storey::cli
