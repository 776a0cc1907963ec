// Test certificates made with the openssl command.
#include "TestCerts.h"

#include <stdexcept>

#include "support/TestSupport.h"

namespace voxbrick::test {
namespace {

/// Runs `command` in a shell; throws with its output unless it exits 0.
std::string run(const std::string& command) {
  const CommandResult r = runShell(command + " 2>&1");
  if (r.exitCode != 0) throw std::runtime_error("'" + command + "' failed: " + r.output);
  return r.output;
}

std::string q(const std::filesystem::path& p) { return "'" + p.string() + "'"; }

/// A P-256 key and a certificate for `subject`, signed by the CA `ca` (`caKey`), with the extensions of `extFile`.
void issue(const std::filesystem::path& dir, const std::string& name, const std::string& subject,
           const std::filesystem::path& ca, const std::filesystem::path& caKey, const std::string& extensions) {
  const auto ext = dir / (name + ".ext");
  writeFile(ext, extensions);
  run("openssl req -newkey ec -pkeyopt ec_paramgen_curve:P-256 -nodes -keyout " + q(dir / (name + ".key")) + " -out " +
      q(dir / (name + ".csr")) + " -subj '" + subject + "'");
  run("openssl x509 -req -in " + q(dir / (name + ".csr")) + " -CA " + q(ca) + " -CAkey " + q(caKey) +
      " -CAcreateserial -days 2 -sha256 -out " + q(dir / (name + ".pem")) + " -extfile " + q(ext));
}

void makeCa(const std::filesystem::path& dir, const std::string& name, const std::string& subject) {
  run("openssl req -x509 -newkey ec -pkeyopt ec_paramgen_curve:P-256 -nodes -days 2 -sha256 -keyout " +
      q(dir / (name + ".key")) + " -out " + q(dir / (name + ".pem")) + " -subj '" + subject +
      "' -addext basicConstraints=critical,CA:TRUE -addext keyUsage=critical,keyCertSign,cRLSign");
}

}  // namespace

TestCerts TestCerts::make(const std::filesystem::path& dir) {
  std::filesystem::create_directories(dir);
  const std::string serverExt =
      "basicConstraints=CA:FALSE\nkeyUsage=digitalSignature\nextendedKeyUsage=serverAuth\n"
      "subjectAltName=IP:127.0.0.1,DNS:localhost\n";
  makeCa(dir, "ca", "/CN=voxbrick test CA");
  makeCa(dir, "wrong-ca", "/CN=voxbrick wrong CA");
  issue(dir, "server", "/CN=voxbrick test server", dir / "ca.pem", dir / "ca.key", serverExt);
  issue(dir, "other", "/CN=voxbrick test server, reissued", dir / "ca.pem", dir / "ca.key", serverExt);
  issue(dir, "wrong", "/CN=voxbrick wrong server", dir / "wrong-ca.pem", dir / "wrong-ca.key", serverExt);
  issue(dir, "elsewhere", "/CN=elsewhere.example", dir / "ca.pem", dir / "ca.key",
        "basicConstraints=CA:FALSE\nextendedKeyUsage=serverAuth\nsubjectAltName=DNS:elsewhere.example\n");
  issue(dir, "client", "/CN=voxbrick test client", dir / "ca.pem", dir / "ca.key",
        "basicConstraints=CA:FALSE\nkeyUsage=digitalSignature\nextendedKeyUsage=clientAuth\n");
  TestCerts c;
  c.caCert = dir / "ca.pem";
  c.serverCert = dir / "server.pem";
  c.serverKey = dir / "server.key";
  c.otherCert = dir / "other.pem";
  c.otherKey = dir / "other.key";
  c.wrongCaCert = dir / "wrong-ca.pem";
  c.wrongCert = dir / "wrong.pem";
  c.wrongKey = dir / "wrong.key";
  c.elsewhereCert = dir / "elsewhere.pem";
  c.elsewhereKey = dir / "elsewhere.key";
  c.clientCert = dir / "client.pem";
  c.clientKey = dir / "client.key";
  return c;
}

std::string TestCerts::spkiHash(const std::filesystem::path& cert) {
  std::string out = run("openssl x509 -in " + q(cert) +
                        " -pubkey -noout | openssl pkey -pubin -outform der | openssl dgst -sha256 -binary | "
                        "openssl enc -base64");
  while (!out.empty() && (out.back() == '\n' || out.back() == '\r')) out.pop_back();
  return out;
}

}  // namespace voxbrick::test
