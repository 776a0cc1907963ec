// What the HTTP side of the browser transport decides, without sockets: the embedded files by name only, the
// Origin rule and the access token of /ws.
#include <gtest/gtest.h>

#include <string>

#include "server/WebFiles.h"
#include "server/WebGate.h"

namespace voxbrick::server {
namespace {

std::string bodyOf(const WebGate::Response& r) { return std::string(r.body.begin(), r.body.end()); }

TEST(WebGate, ServesTheEmbeddedFilesByNameOnly) {
  const WebGate gate({}, "");
  const WebFile* index = findWebFile("index.html");
  ASSERT_NE(index, nullptr) << "web/index.html is embedded";
  EXPECT_EQ(index->contentType, "text/html; charset=utf-8");
  const WebGate::Response root = gate.respond("GET", "/", "");
  EXPECT_EQ(root.status, 200);
  EXPECT_EQ(bodyOf(root), std::string(index->bytes.begin(), index->bytes.end()));
  EXPECT_EQ(gate.respond("HEAD", "/index.html?x=1", "").status, 200);
  EXPECT_EQ(gate.respond("GET", "/", root.etag).status, 304);
  EXPECT_EQ(gate.respond("GET", "/", "\"other\"").status, 200);
  for (const char* target : {"/../CMakeLists.txt", "/%2e%2e/", "//index.html", "index.html", "", "/ index.html",
                             "/index.html#x", "http://h/index.html", "/INDEX.HTML", "/web/index.html"})
    EXPECT_EQ(gate.respond("GET", target, "").status, 404) << target;
  EXPECT_EQ(gate.respond("POST", "/", "").status, 405);
  EXPECT_EQ(gate.respond("get", "/", "").status, 405) << "methods are case-sensitive";
  EXPECT_EQ(gate.respond("GET", "/ws?token=x", "").status, 426);
}

TEST(WebGate, APlainRequestForTheSocketPathSaysWhenItsTokenIsWrong) {
  const WebGate gate({}, "secret-1");
  EXPECT_EQ(gate.respond("GET", "/ws?token=secret-1", "").status, 426);
  const WebGate::Response wrong = gate.respond("GET", "/ws?token=x", "");
  EXPECT_EQ(wrong.status, 403);
  EXPECT_NE(wrong.text.find("wrong access token"), std::string::npos);
  const WebGate::Response missing = gate.respond("GET", "/ws", "");
  EXPECT_EQ(missing.status, 403);
  EXPECT_NE(missing.text.find("token is required"), std::string::npos);
}

TEST(WebGate, ThePresetsAreServedBehindTheTokenAndReadableByConfiguredOriginsOnly) {
  const std::string presets = R"([{"name":"mri","points":[[0,0,0,0,0],[1,1,1,1,0.5]]}])";
  const WebGate gate({"https://lab.example.org"}, "secret-1", presets);
  const WebGate::Response ok = gate.respond("GET", "/presets.json?token=secret-1", "");
  EXPECT_EQ(ok.status, 200);
  EXPECT_EQ(ok.contentType, "application/json");
  EXPECT_EQ(bodyOf(ok), presets);
  EXPECT_EQ(ok.allowOrigin, "") << "the page's own origin needs no header";
  EXPECT_EQ(gate.respond("GET", "/presets.json?token=secret-1", "", "https://lab.example.org").allowOrigin,
            "https://lab.example.org");
  EXPECT_EQ(gate.respond("GET", "/presets.json?token=secret-1", "", "https://elsewhere.example").allowOrigin, "");
  const WebGate::Response wrong = gate.respond("GET", "/presets.json?token=x", "", "https://lab.example.org");
  EXPECT_EQ(wrong.status, 403);
  EXPECT_NE(wrong.text.find("wrong access token"), std::string::npos);
  EXPECT_EQ(wrong.allowOrigin, "");
  EXPECT_EQ(gate.respond("GET", "/presets.json", "").status, 403);
  EXPECT_EQ(WebGate({}, "").respond("GET", "/presets.json", "").status, 200);
}

TEST(WebGate, TheMetricsAreServedBehindTheTokenInTheQueryOrABearerHeader) {
  int calls = 0;
  const WebGate gate({"https://lab.example.org"}, "secret-1", "[]", [&calls] {
    ++calls;
    return std::string("# HELP demo_total Demo.\n# TYPE demo_total counter\ndemo_total 1\n");
  });
  const WebGate::Response query = gate.respond("GET", "/metrics?token=secret-1", "");
  EXPECT_EQ(query.status, 200);
  EXPECT_EQ(query.contentType, "text/plain; version=0.0.4; charset=utf-8");
  EXPECT_EQ(query.text, "# HELP demo_total Demo.\n# TYPE demo_total counter\ndemo_total 1\n");
  EXPECT_TRUE(query.etag.empty()) << "never cached";
  EXPECT_EQ(calls, 1) << "made for each request";
  for (const char* header : {"Bearer secret-1", "bearer secret-1", "BEARER  secret-1 "})
    EXPECT_EQ(gate.respond("GET", "/metrics", "", "", header).status, 200) << header;
  for (const char* header : {"", "Bearer secret-2", "Basic c2VjcmV0LTE=", "secret-1", "Bearer", "Bearer "}) {
    const WebGate::Response r = gate.respond("GET", "/metrics", "", "", header);
    EXPECT_EQ(r.status, 403) << header;
    EXPECT_TRUE(r.text.starts_with("forbidden:")) << r.text;
  }
  EXPECT_EQ(calls, 4) << "nothing is made for a refused request";
  EXPECT_NE(gate.respond("GET", "/metrics", "", "", "Bearer nope").text.find("wrong access token"), std::string::npos);
  EXPECT_EQ(gate.respond("GET", "/metrics?token=wrong", "", "", "Bearer secret-1").status, 403)
      << "the query's token is the one checked when both are given";
  EXPECT_EQ(gate.respond("GET", "/presets.json", "", "", "Bearer secret-1").status, 200) << "the presets too";
  EXPECT_EQ(gate.respond("GET", "/metrics?token=secret-1", "", "https://lab.example.org").allowOrigin,
            "https://lab.example.org");
  EXPECT_EQ(gate.respond("POST", "/metrics?token=secret-1", "").status, 405);
  EXPECT_EQ(WebGate({}, "").respond("GET", "/metrics", "").status, 404) << "no metrics given: no such path";
  EXPECT_EQ(WebGate({}, "", "[]", [] { return std::string("x 1\n"); }).respond("GET", "/metrics", "").status, 200)
      << "no token set: open";
}

TEST(WebGate, ContentTypesFollowTheExtension) {
  EXPECT_EQ(contentTypeOf("a/b.js"), "text/javascript; charset=utf-8");
  EXPECT_EQ(contentTypeOf("style.css"), "text/css; charset=utf-8");
  EXPECT_EQ(contentTypeOf("icon.svg"), "image/svg+xml");
  EXPECT_EQ(contentTypeOf("x.png"), "image/png");
  EXPECT_EQ(contentTypeOf("data.bin"), "application/octet-stream");
  EXPECT_EQ(contentTypeOf("dir.d/file"), "application/octet-stream");
}

TEST(WebGate, ParsesOrigins) {
  const auto o = WebGate::parseOrigin("HTTPS://Lab.Example.org");
  ASSERT_TRUE(o);
  EXPECT_EQ(*o, (WebGate::Origin{"https", "lab.example.org", 443}));
  EXPECT_EQ(WebGate::parseOrigin("http://h:8080/")->port, 8080);
  EXPECT_EQ(WebGate::parseOrigin("http://[::1]:9000")->host, "[::1]");
  for (const char* bad : {"null", "h:80", "ftp://h", "http://", "http://h:0", "http://h:99999", "http://h:x",
                          "http://h/path", "http://u@h", "http://h?q"})
    EXPECT_FALSE(WebGate::parseOrigin(bad)) << bad;
  EXPECT_THROW(WebGate({"nope"}, ""), std::invalid_argument);
}

TEST(WebGate, TheUpgradeNeedsAnAllowedOriginAndTheToken) {
  const WebGate open({}, "");
  EXPECT_FALSE(open.refuseUpgrade("/ws", std::nullopt, "h:1")) << "no Origin: not a browser";
  EXPECT_FALSE(open.refuseUpgrade("/ws", "http://h:1", "h:1")) << "same origin";
  EXPECT_FALSE(open.refuseUpgrade("/ws", "http://H", "h:80")) << "default ports, any case";
  EXPECT_TRUE(open.refuseUpgrade("/ws", "http://h:2", "h:1"));
  EXPECT_FALSE(open.refuseUpgrade("/ws", "https://h:1", "h:1")) << "Host names no scheme (a proxy may add TLS)";
  EXPECT_TRUE(open.refuseUpgrade("/ws", "http://evil.org", "h:1"));
  EXPECT_TRUE(open.refuseUpgrade("/ws", "null", "h:1"));
  EXPECT_TRUE(open.refuseUpgrade("/other", std::nullopt, "h:1"));

  const WebGate listed({"https://lab.org"}, "t0k");
  EXPECT_FALSE(listed.refuseUpgrade("/ws?token=t0k", "https://lab.org:443", "h:1"));
  EXPECT_FALSE(listed.refuseUpgrade("/ws?a=1&token=t0k&b", "http://h:1", "h:1")) << "its own origin still";
  EXPECT_TRUE(listed.refuseUpgrade("/ws?token=t0k", "http://lab.org", "h:1")) << "another scheme, another origin";
  EXPECT_NE(listed.refuseUpgrade("/ws", std::nullopt, "h:1").value_or("").find("token is required"), std::string::npos);
  EXPECT_TRUE(listed.refuseUpgrade("/ws?token=t0", std::nullopt, "h:1"));
  EXPECT_TRUE(listed.refuseUpgrade("/ws?token=t0kk", std::nullopt, "h:1"));
  EXPECT_TRUE(listed.refuseUpgrade("/ws?token=", std::nullopt, "h:1"));
  EXPECT_TRUE(listed.refuseUpgrade("/ws?xtoken=t0k", std::nullopt, "h:1"));
  EXPECT_TRUE(WebGate::validToken("aZ0-._~"));
  EXPECT_FALSE(WebGate::validToken(""));
  EXPECT_FALSE(WebGate::validToken("a b"));
  EXPECT_FALSE(WebGate::validToken("a&b"));
}

}  // namespace
}  // namespace voxbrick::server
