#include "storey/runtime/security.h"

#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "storey/common/file_checks.h"

namespace fs = std::filesystem;

namespace storey::runtime {
namespace {

constexpr const char* kCaCert = "ca.cert.pem";
constexpr const char* kCaKey = "ca.key.pem";
constexpr const char* kGovernance = "governance.p7s";

std::string shellQuote(const std::string& s) {
  std::string out = "'";
  for (char c : s) {
    if (c == '\'') {
      out += "'\\''";
    } else {
      out += c;
    }
  }
  return out + "'";
}

// Runs openssl; returns its stdout. Throws naming `step` with openssl's own message.
std::string runOpenssl(const SecurityInitOptions& options, const std::vector<std::string>& args,
                       const std::string& step) {
  std::string command = shellQuote(options.openssl);
  for (const std::string& a : args) command += " " + shellQuote(a);
  command += " 2>&1";
  FILE* pipe = popen(command.c_str(), "r");
  if (!pipe)
    throw std::runtime_error("security: cannot run " + options.openssl + " (" + step + ")");
  std::string output;
  char buffer[4096];
  std::size_t n;
  while ((n = std::fread(buffer, 1, sizeof buffer, pipe)) > 0) output.append(buffer, n);
  const int status = pclose(pipe);
  if (status != 0) {
    throw std::runtime_error("security: " + step + " failed (" + options.openssl + " exit status " +
                             std::to_string(status) + "): " + output);
  }
  return output;
}

void writeText(const fs::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::trunc);
  out << text;
  if (!out) throw std::runtime_error("security: cannot write " + path.string());
}

std::string xmlEscape(const std::string& s) {
  std::string out;
  for (char c : s) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

std::string isoUtc(std::time_t t) {
  std::tm tm{};
  gmtime_r(&t, &tm);
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%S", &tm);
  return text;
}

void checkParticipantName(const std::string& name) {
  if (name.empty()) throw std::runtime_error("security: empty participant name");
  for (char c : name) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                    c == '_' || c == '-';
    if (!ok) {
      throw std::runtime_error("security: participant name '" + name +
                               "' may hold only letters, digits, '_' and '-'");
    }
  }
}

void signDocument(const fs::path& folder, const fs::path& xml, const fs::path& p7s,
                  const SecurityInitOptions& options, const std::string& step) {
  runOpenssl(options,
             {"smime", "-sign", "-text", "-in", xml.string(), "-out", p7s.string(), "-signer",
              (folder / kCaCert).string(), "-inkey", (folder / kCaKey).string()},
             step);
}

}  // namespace

bool SecurityOptions::enabled() const {
  return !identity_ca.empty() || !identity_certificate.empty() || !private_key.empty() ||
         !permissions_ca.empty() || !governance.empty() || !permissions.empty();
}

SecurityOptions securityFromFolder(const std::string& folder, const std::string& participant) {
  const fs::path root(folder);
  const fs::path own = root / participant;
  SecurityOptions options;
  options.identity_ca = (root / kCaCert).string();
  options.permissions_ca = options.identity_ca;
  options.governance = (root / kGovernance).string();
  options.identity_certificate = (own / "cert.pem").string();
  options.private_key = (own / "key.pem").string();
  options.permissions = (own / "permissions.p7s").string();
  for (const std::string* path :
       {&options.identity_ca, &options.governance, &options.identity_certificate,
        &options.private_key, &options.permissions}) {
    if (!fs::is_regular_file(*path)) {
      throw std::runtime_error("security folder " + folder + " has no " + *path +
                               " (participant '" + participant +
                               "'; see storey security init --help)");
    }
  }
  return options;
}

void validateSecurityOptions(const SecurityOptions& options) {
  if (!options.enabled()) return;
  const std::pair<const char*, const std::string*> fields[] = {
      {"identity_ca", &options.identity_ca},
      {"identity_certificate", &options.identity_certificate},
      {"private_key", &options.private_key},
      {"permissions_ca", &options.permissions_ca},
      {"governance", &options.governance},
      {"permissions", &options.permissions}};
  for (const auto& [name, path] : fields) {
    if (path->empty()) {
      throw std::runtime_error(std::string("security option ") + name +
                               " is empty while others are set (all six are needed)");
    }
    try {
      common::requireRegularFile(*path, "security file");  // a FIFO would block its reader
    } catch (const std::runtime_error& e) {
      throw std::runtime_error(std::string("security option ") + name + ": " + e.what());
    }
    if (!std::ifstream(*path).good()) {
      throw std::runtime_error(std::string("security option ") + name + ": cannot read " + *path);
    }
  }
}

std::vector<std::pair<std::string, std::string>> securityProperties(
    const SecurityOptions& options) {
  validateSecurityOptions(options);
  if (!options.enabled()) return {};
  auto uri = [](const std::string& path) { return "file://" + fs::absolute(path).string(); };
  const std::string auth = "dds.sec.auth.builtin.PKI-DH.";
  const std::string access = "dds.sec.access.builtin.Access-Permissions.";
  return {{"dds.sec.auth.plugin", "builtin.PKI-DH"},
          {auth + "identity_ca", uri(options.identity_ca)},
          {auth + "identity_certificate", uri(options.identity_certificate)},
          {auth + "private_key", uri(options.private_key)},
          {"dds.sec.access.plugin", "builtin.Access-Permissions"},
          {access + "permissions_ca", uri(options.permissions_ca)},
          {access + "governance", uri(options.governance)},
          {access + "permissions", uri(options.permissions)},
          {"dds.sec.crypto.plugin", "builtin.AES-GCM-GMAC"}};
}

std::string governanceXml(int domain_min, int domain_max) {
  std::ostringstream out;
  out << R"(<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance"
     xsi:noNamespaceSchemaLocation="http://www.omg.org/spec/DDS-Security/20170801/omg_shared_ca_governance.xsd">
  <domain_access_rules>
    <domain_rule>
      <domains>
        <id_range><min>)"
      << domain_min << "</min><max>" << domain_max << R"(</max></id_range>
      </domains>
      <allow_unauthenticated_participants>false</allow_unauthenticated_participants>
      <enable_join_access_control>true</enable_join_access_control>
      <discovery_protection_kind>ENCRYPT</discovery_protection_kind>
      <liveliness_protection_kind>ENCRYPT</liveliness_protection_kind>
      <rtps_protection_kind>ENCRYPT</rtps_protection_kind>
      <topic_access_rules>
        <topic_rule>
          <topic_expression>*</topic_expression>
          <enable_discovery_protection>true</enable_discovery_protection>
          <enable_liveliness_protection>true</enable_liveliness_protection>
          <enable_read_access_control>true</enable_read_access_control>
          <enable_write_access_control>true</enable_write_access_control>
          <metadata_protection_kind>ENCRYPT</metadata_protection_kind>
          <data_protection_kind>ENCRYPT</data_protection_kind>
        </topic_rule>
      </topic_access_rules>
    </domain_rule>
  </domain_access_rules>
</dds>
)";
  return out.str();
}

std::string permissionsXml(const std::string& subject_rfc2253, const TopicGrant& grant,
                           int domain_min, int domain_max, int validity_days) {
  const std::time_t now = std::time(nullptr);
  std::ostringstream out;
  out << R"(<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance"
     xsi:noNamespaceSchemaLocation="http://www.omg.org/spec/DDS-Security/20170801/omg_shared_ca_permissions.xsd">
  <permissions>
    <grant name=")"
      << xmlEscape(grant.participant) << R"(_grant">
      <subject_name>)"
      << xmlEscape(subject_rfc2253) << R"(</subject_name>
      <validity>
        <not_before>)"
      << isoUtc(now - 86400) << "</not_before>\n        <not_after>"
      << isoUtc(now + std::time_t(validity_days) * 86400) << R"(</not_after>
      </validity>
)";
  if (!grant.publish.empty() || !grant.subscribe.empty()) {
    out << "      <allow_rule>\n        <domains>\n          <id_range><min>" << domain_min
        << "</min><max>" << domain_max << "</max></id_range>\n        </domains>\n";
    for (const auto& [element, topics] :
         {std::pair{"publish", &grant.publish}, std::pair{"subscribe", &grant.subscribe}}) {
      if (topics->empty()) continue;
      out << "        <" << element << ">\n          <topics>\n";
      for (const std::string& topic : *topics) {
        out << "            <topic>" << xmlEscape(topic) << "</topic>\n";
      }
      out << "          </topics>\n        </" << element << ">\n";
    }
    out << "      </allow_rule>\n";
  }
  out << "      <default>DENY</default>\n    </grant>\n  </permissions>\n</dds>\n";
  return out.str();
}

void addSecurityParticipant(const std::string& folder, const TopicGrant& grant,
                            const SecurityInitOptions& options) {
  checkParticipantName(grant.participant);
  const fs::path root(folder);
  if (!fs::is_regular_file(root / kCaKey)) {
    throw std::runtime_error("security: " + (root / kCaKey).string() +
                             " does not exist (run storey security init first)");
  }
  const fs::path own = root / grant.participant;
  if (fs::exists(own / "cert.pem")) {
    throw std::runtime_error("security: participant '" + grant.participant +
                             "' already exists in " + folder);
  }
  fs::create_directories(own);
  const std::string who = "participant '" + grant.participant + "': ";
  runOpenssl(
      options,
      {"ecparam", "-name", "prime256v1", "-genkey", "-noout", "-out", (own / "key.pem").string()},
      who + "key generation");
  fs::permissions(own / "key.pem", fs::perms::owner_read | fs::perms::owner_write);
  runOpenssl(options,
             {"req", "-new", "-key", (own / "key.pem").string(), "-subj",
              "/O=storey/CN=" + grant.participant, "-out", (own / "cert.csr").string()},
             who + "certificate request");
  // A serial from the clock and name, so two participants never share one.
  const std::string serial = std::to_string(std::time(nullptr)) +
                             std::to_string(std::hash<std::string>{}(grant.participant) % 1000000);
  runOpenssl(
      options,
      {"x509", "-req", "-in", (own / "cert.csr").string(), "-CA", (root / kCaCert).string(),
       "-CAkey", (root / kCaKey).string(), "-set_serial", serial, "-days",
       std::to_string(options.validity_days), "-sha256", "-out", (own / "cert.pem").string()},
      who + "certificate signing");
  fs::remove(own / "cert.csr");
  std::string subject = runOpenssl(
      options,
      {"x509", "-in", (own / "cert.pem").string(), "-noout", "-subject", "-nameopt", "RFC2253"},
      who + "reading the certificate subject");
  // "subject=CN=x,O=storey\n"
  if (subject.rfind("subject=", 0) == 0) subject = subject.substr(8);
  while (!subject.empty() && (subject.back() == '\n' || subject.back() == ' ')) subject.pop_back();
  writeText(own / "permissions.xml", permissionsXml(subject, grant, options.domain_min,
                                                    options.domain_max, options.validity_days));
  signDocument(root, own / "permissions.xml", own / "permissions.p7s", options,
               who + "signing the permissions");
}

void initSecurityFolder(const SecurityInitOptions& options) {
  if (options.output_dir.empty()) throw std::runtime_error("security: no output folder");
  if (options.domain_min < 0 || options.domain_max > 232 ||
      options.domain_min > options.domain_max) {
    throw std::runtime_error("security: domain range must lie within [0, 232]");
  }
  const fs::path root(options.output_dir);
  if (fs::exists(root / kCaKey)) {
    throw std::runtime_error("security: " + options.output_dir +
                             " already holds a CA; choose an empty folder");
  }
  fs::create_directories(root);
  runOpenssl(
      options,
      {"ecparam", "-name", "prime256v1", "-genkey", "-noout", "-out", (root / kCaKey).string()},
      "CA key generation");
  fs::permissions(root / kCaKey, fs::perms::owner_read | fs::perms::owner_write);
  runOpenssl(options,
             {"req", "-x509", "-new", "-key", (root / kCaKey).string(), "-subj",
              "/O=storey/CN=storey CA", "-days", std::to_string(options.validity_days), "-sha256",
              "-out", (root / kCaCert).string()},
             "CA certificate");
  writeText(root / "governance.xml", governanceXml(options.domain_min, options.domain_max));
  signDocument(root, root / "governance.xml", root / kGovernance, options,
               "signing the governance");
  for (const TopicGrant& grant : options.grants) {
    addSecurityParticipant(options.output_dir, grant, options);
  }
}

}  // namespace storey::runtime
