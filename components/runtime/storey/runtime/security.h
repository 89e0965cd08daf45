// DDS Security (authentication, access control, encryption) for a Context, and the
// artifacts it needs. No Fast DDS header here: Context applies the properties.
//
// A security folder made by `storey security init` (initSecurityFolder) holds
//   ca.cert.pem, ca.key.pem          the CA (identity CA and permissions CA)
//   governance.xml, governance.p7s   join access control on, everything encrypted
//   <participant>/cert.pem, key.pem  the participant's identity (subject CN=<participant>,O=storey)
//   <participant>/permissions.xml, permissions.p7s  its signed grant (default DENY)
// Keep ca.key.pem off the robots: only init needs it.
#pragma once

#include <string>
#include <utility>
#include <vector>

namespace storey::runtime {

// Paths of the six files a secured participant needs; all empty: no security.
struct SecurityOptions {
  std::string identity_ca;           // CA that signed the participants' certificates
  std::string identity_certificate;  // this participant's certificate
  std::string private_key;           // this participant's key
  std::string permissions_ca;        // CA that signed governance and permissions
  std::string governance;            // signed governance (.p7s)
  std::string permissions;           // this participant's signed permissions (.p7s)

  bool enabled() const;
};

// The options for `participant` in a security folder laid out as above. Throws
// std::runtime_error naming the folder and the missing file.
SecurityOptions securityFromFolder(const std::string& folder, const std::string& participant);

// Checks that either no path or all six are set and that each names a readable file;
// throws std::runtime_error naming the field and path otherwise.
void validateSecurityOptions(const SecurityOptions& options);

// Why Fast DDS would refuse these files, found with the openssl program: the first check
// that fails, naming the option, its file and the check ("governance /s/governance.p7s:
// its signature does not verify against permissions_ca /s/ca.cert.pem"), or "" when all
// pass. Checks: the CA files are certificates; the identity certificate verifies against
// the identity CA and has not expired; the private key belongs to it; governance and
// permissions verify against the permissions CA; the permissions grant the certificate's
// subject. Context calls it when a secured participant cannot be created.
std::string diagnoseSecurityFiles(const SecurityOptions& options,
                                  const std::string& openssl = "openssl");

// The DomainParticipant properties that enable the builtin plugins (PKI-DH,
// Access-Permissions, AES-GCM-GMAC) with these files ("file:" URIs, absolute paths).
std::vector<std::pair<std::string, std::string>> securityProperties(const SecurityOptions& options);

// What one participant may publish and subscribe to: DDS topic names or fnmatch
// patterns ("rt/robot1/scan", "rt/*").
struct TopicGrant {
  std::string participant;
  std::vector<std::string> publish;
  std::vector<std::string> subscribe;
};

struct SecurityInitOptions {
  std::string output_dir;  // created; must not already hold a CA
  std::vector<TopicGrant> grants;
  int domain_min = 0, domain_max = 232;
  int validity_days = 3650;
  std::string openssl = "openssl";  // program
};

// Makes the CA, each participant's key, certificate and signed permissions, and the
// signed governance, with the openssl program. Throws std::runtime_error naming the step
// (and openssl's message) on failure.
void initSecurityFolder(const SecurityInitOptions& options);

// Adds one participant (a new identity and grant) to an existing folder, signed by its CA.
void addSecurityParticipant(const std::string& folder, const TopicGrant& grant,
                            const SecurityInitOptions& options);

// The governance and permissions documents (exposed for tests and docs).
std::string governanceXml(int domain_min, int domain_max);
std::string permissionsXml(const std::string& subject_rfc2253, const TopicGrant& grant,
                           int domain_min, int domain_max, int validity_days);

}  // namespace storey::runtime
