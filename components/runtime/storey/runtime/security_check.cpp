// diagnoseSecurityFiles: the checks Fast DDS's security plugins make, run with openssl so
// that a refused participant's error names the file and the check it fails.
#include <cstdio>
#include <string>
#include <vector>

#include "storey/runtime/security.h"

namespace storey::runtime {
namespace {

std::string quoted(const std::string& s) {
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

struct Run {
  int status = -1;
  std::string output;  // stdout (stderr too when `with_errors`)
};

Run run(const std::string& openssl, const std::vector<std::string>& args, bool with_errors) {
  std::string command = quoted(openssl);
  for (const auto& a : args) command += " " + quoted(a);
  command += with_errors ? " 2>&1" : " 2>/dev/null";
  Run r;
  FILE* pipe = popen(command.c_str(), "r");
  if (!pipe) return r;
  char buffer[4096];
  std::size_t n;
  while ((n = std::fread(buffer, 1, sizeof buffer, pipe)) > 0) r.output.append(buffer, n);
  r.status = pclose(pipe);
  return r;
}

// openssl's first line, for a message.
std::string firstLine(const std::string& text) {
  const auto end = text.find('\n');
  return end == std::string::npos ? text : text.substr(0, end);
}

std::string between(const std::string& text, const std::string& open, const std::string& close) {
  const auto a = text.find(open);
  if (a == std::string::npos) return "";
  const auto b = text.find(close, a + open.size());
  return b == std::string::npos ? "" : text.substr(a + open.size(), b - a - open.size());
}

}  // namespace

std::string diagnoseSecurityFiles(const SecurityOptions& o, const std::string& openssl) {
  if (!o.enabled()) return "";
  try {
    validateSecurityOptions(o);
  } catch (const std::exception& e) {
    return e.what();
  }
  if (run(openssl, {"version"}, false).status != 0) return "";  // no openssl: nothing to say
  for (const auto& [name, path] :
       {std::pair<const char*, const std::string*>{"identity_ca", &o.identity_ca},
        {"permissions_ca", &o.permissions_ca},
        {"identity_certificate", &o.identity_certificate}}) {
    if (run(openssl, {"x509", "-in", *path, "-noout"}, false).status != 0)
      return std::string(name) + " " + *path + ": not a PEM certificate";
  }
  const Run verified =
      run(openssl, {"verify", "-CAfile", o.identity_ca, o.identity_certificate}, true);
  if (verified.status != 0)
    return "identity_certificate " + o.identity_certificate +
           ": does not verify against identity_ca " + o.identity_ca +
           " (openssl: " + firstLine(verified.output) + ")";
  if (run(openssl, {"x509", "-in", o.identity_certificate, "-noout", "-checkend", "0"}, false)
          .status != 0)
    return "identity_certificate " + o.identity_certificate + ": has expired";
  const Run key = run(openssl, {"pkey", "-in", o.private_key, "-pubout"}, false);
  if (key.status != 0) return "private_key " + o.private_key + ": not a readable private key";
  const Run certificate_key =
      run(openssl, {"x509", "-in", o.identity_certificate, "-noout", "-pubkey"}, false);
  if (certificate_key.output != key.output)
    return "private_key " + o.private_key + ": does not belong to identity_certificate " +
           o.identity_certificate;
  std::string granted;
  for (const auto& [name, path] :
       {std::pair<const char*, const std::string*>{"governance", &o.governance},
        {"permissions", &o.permissions}}) {
    const Run signed_document =
        run(openssl, {"smime", "-verify", "-in", *path, "-CAfile", o.permissions_ca}, false);
    if (signed_document.status != 0)
      return std::string(name) + " " + *path +
             ": its signature does not verify against permissions_ca " + o.permissions_ca +
             " (altered after signing, or signed by another CA)";
    if (std::string(name) == "permissions")
      granted = between(signed_document.output, "<subject_name>", "</subject_name>");
  }
  const Run subject = run(
      openssl, {"x509", "-in", o.identity_certificate, "-noout", "-subject", "-nameopt", "RFC2253"},
      false);
  std::string holder = firstLine(subject.output);
  if (holder.rfind("subject=", 0) == 0) holder = holder.substr(8);
  if (!granted.empty() && !holder.empty() && granted != holder)
    return "permissions " + o.permissions + ": grants subject '" + granted +
           "', but identity_certificate " + o.identity_certificate + " is '" + holder + "'";
  return "";
}

}  // namespace storey::runtime
