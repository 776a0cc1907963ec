// TOML configuration through toml++: every key is known, typed and range-checked.
#include "server/ServerConfig.h"

#include <set>
#include <stdexcept>

#include <toml++/toml.h>

namespace voxbrick::server {
namespace {

[[noreturn]] void fail(const std::string& what) { throw std::runtime_error(what); }

template <typename T>
void read(const toml::table& table, const std::string& section, const char* key, T& out, const std::string& file) {
  const toml::node* node = table.get(key);
  if (!node) return;
  const std::string name = file + ": " + section + "." + key;
  if constexpr (std::is_same_v<T, bool>) {
    if (!node->is_boolean()) fail(name + " must be true or false");
    out = node->as_boolean()->get();
  } else if constexpr (std::is_same_v<T, std::string>) {
    if (!node->is_string()) fail(name + " must be a string");
    out = node->as_string()->get();
  } else if constexpr (std::is_same_v<T, std::filesystem::path>) {
    if (!node->is_string()) fail(name + " must be a string");
    out = node->as_string()->get();
  } else if constexpr (std::is_same_v<T, double>) {
    if (!node->is_number()) fail(name + " must be a number");
    out = node->value<double>().value();
  } else {
    if (!node->is_integer()) fail(name + " must be an integer");
    const int64_t v = node->as_integer()->get();
    if (v < 0 || uint64_t(v) > uint64_t(std::numeric_limits<T>::max())) fail(name + " = " + std::to_string(v) + " is out of range");
    out = T(v);
  }
}

void checkKeys(const toml::table& table, const std::string& section, const std::set<std::string>& known,
               const std::string& file) {
  for (const auto& [key, node] : table) {
    if (!known.count(std::string(key.str())))
      fail(file + ": unknown key " + (section.empty() ? "" : section + ".") + std::string(key.str()));
  }
}

}  // namespace

ServerConfig ServerConfig::load(const std::filesystem::path& path) {
  const std::string file = path.string();
  toml::table root;
  try {
    root = toml::parse_file(file);
  } catch (const toml::parse_error& e) {
    fail(file + ":" + std::to_string(e.source().begin.line) + ": " + std::string(e.description()));
  }
  checkKeys(root, "", {"server", "limits", "memory"}, file);
  ServerConfig c;
  auto section = [&](const char* name) -> const toml::table* {
    const toml::node* node = root.get(name);
    if (!node) return nullptr;
    if (!node->is_table()) fail(file + ": " + name + " must be a table");
    return node->as_table();
  };
  if (const toml::table* s = section("server")) {
    checkKeys(*s, "server", {"host", "port", "datasets", "io_threads", "render_threads", "backend", "log_level", "coalesce"}, file);
    read(*s, "server", "host", c.host, file);
    read(*s, "server", "port", c.port, file);
    read(*s, "server", "datasets", c.datasets, file);
    read(*s, "server", "io_threads", c.ioThreads, file);
    read(*s, "server", "render_threads", c.renderThreads, file);
    read(*s, "server", "backend", c.backend, file);
    read(*s, "server", "log_level", c.logLevel, file);
    read(*s, "server", "coalesce", c.coalesce, file);
    // A relative dataset directory is relative to the configuration file.
    if (s->get("datasets") && c.datasets.is_relative()) c.datasets = path.parent_path() / c.datasets;
  }
  if (const toml::table* l = section("limits")) {
    checkKeys(*l, "limits", {"max_sessions", "max_message_bytes", "max_image_side", "idle_timeout_s", "read_timeout_s",
                             "write_timeout_s", "max_output_bytes"}, file);
    read(*l, "limits", "max_sessions", c.maxSessions, file);
    read(*l, "limits", "max_message_bytes", c.maxMessageBytes, file);
    read(*l, "limits", "max_image_side", c.maxImageSide, file);
    read(*l, "limits", "idle_timeout_s", c.idleTimeoutS, file);
    read(*l, "limits", "read_timeout_s", c.readTimeoutS, file);
    read(*l, "limits", "write_timeout_s", c.writeTimeoutS, file);
    read(*l, "limits", "max_output_bytes", c.maxOutputBytes, file);
  }
  if (const toml::table* m = section("memory")) {
    checkKeys(*m, "memory", {"host_cache_mb", "gpu_budget_mb"}, file);
    read(*m, "memory", "host_cache_mb", c.hostCacheMB, file);
    read(*m, "memory", "gpu_budget_mb", c.gpuBudgetMB, file);
  }
  try {
    c.validate();
  } catch (const std::exception& e) {
    fail(file + ": " + e.what());
  }
  return c;
}

void ServerConfig::validate() const {
  auto range = [](const std::string& name, double v, double lo, double hi) {
    if (!(v >= lo && v <= hi))
      fail(name + " = " + std::to_string(v) + " is outside [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
  };
  range("server.port", port, 0, 65535);
  range("server.io_threads", ioThreads, 1, 64);
  range("server.render_threads", renderThreads, 1, 64);
  if (backend != "auto" && backend != "egl" && backend != "osmesa")
    fail("server.backend = '" + backend + "' must be auto, egl or osmesa");
  static const std::set<std::string> levels = {"trace", "debug", "info", "warn", "error", "off"};
  if (!levels.count(logLevel)) fail("server.log_level = '" + logLevel + "' is not a log level");
  range("limits.max_sessions", maxSessions, 1, 100000);
  range("limits.max_message_bytes", maxMessageBytes, 1024, 64 << 20);
  range("limits.max_image_side", maxImageSide, 1, 8192);
  range("limits.idle_timeout_s", idleTimeoutS, 0.1, 86400);
  range("limits.read_timeout_s", readTimeoutS, 0.1, 3600);
  range("limits.write_timeout_s", writeTimeoutS, 0.1, 3600);
  range("limits.max_output_bytes", double(maxOutputBytes), 1 << 20, double(uint64_t(1) << 40));
  range("memory.host_cache_mb", double(hostCacheMB), 16, 1 << 22);
  range("memory.gpu_budget_mb", double(gpuBudgetMB), 16, 1 << 22);
}

}  // namespace voxbrick::server
