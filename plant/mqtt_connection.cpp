// One MQTT 5 client connection through libmosquitto, driven by the caller's thread (mqtt_connection.hpp).
#include "plant/mqtt_connection.hpp"

#include <mosquitto.h>
#include <mqtt_protocol.h>

#include <poll.h>
#include <sys/eventfd.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <mutex>
#include <stdexcept>

namespace guideway::plant {

namespace {

void init_library() {
  static std::once_flag once;
  std::call_once(once, [] { mosquitto_lib_init(); });  // never cleaned up: other connections may live on
}

MqttConnection::Callbacks& callbacks_of(void* obj) { return *static_cast<MqttConnection::Callbacks*>(obj); }

void check(int rc, const std::string& what) {
  if (rc != MOSQ_ERR_SUCCESS) throw std::runtime_error(what + ": " + mosquitto_error_text(rc));
}

}  // namespace

std::string mosquitto_error_text(int rc) {
  std::string text = mosquitto_strerror(rc);  // "The connection was lost.": a clause in our messages
  if (!text.empty() && text.back() == '.') text.pop_back();
  return text;
}

std::string read_password_file(const std::string& path) {
  struct stat st {};
  if (stat(path.c_str(), &st) != 0) throw std::runtime_error("cannot read " + path + ": " + std::strerror(errno));
  if ((st.st_mode & (S_IROTH | S_IWOTH)) != 0)
    throw std::runtime_error(
        path + " can be read or written by every user: chmod 0600 (or 0640 with the daemon's group) first");
  if (!S_ISREG(st.st_mode)) throw std::runtime_error(path + " is not a regular file");
  std::ifstream in(path);
  std::string password;
  if (!in || !std::getline(in, password))
    throw std::runtime_error(path + " is empty or unreadable: the password is its first line");
  if (!password.empty() && password.back() == '\r') password.pop_back();
  if (password.empty()) throw std::runtime_error(path + " is empty: the password is its first line");
  return password;
}

std::string mqtt_reason_text(int reason_code) { return mosquitto_reason_string(reason_code); }

MqttConnection::MqttConnection(ConnectionSettings settings, Callbacks callbacks)
    : settings_(std::move(settings)), callbacks_(std::move(callbacks)) {
  init_library();
  wake_fd_ = eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  if (wake_fd_ < 0) throw std::runtime_error(std::string("eventfd: ") + std::strerror(errno));
  mosq_ = mosquitto_new(settings_.client_id.empty() ? nullptr : settings_.client_id.c_str(),
                        settings_.session_expiry_s == 0, &callbacks_);
  if (mosq_ == nullptr) {
    close(wake_fd_);
    throw std::runtime_error("mosquitto_new failed (out of memory?)");
  }
  try {
    check(mosquitto_int_option(mosq_, MOSQ_OPT_PROTOCOL_VERSION, MQTT_PROTOCOL_V5), "MQTT v5");
    mosquitto_int_option(mosq_, MOSQ_OPT_TCP_NODELAY, 1);
    if (!settings_.username.empty()) {
      check(mosquitto_username_pw_set(mosq_, settings_.username.c_str(),
                                      settings_.password.empty() ? nullptr : settings_.password.c_str()),
            "username");
    }
    if (settings_.broker.tls) {
      if (settings_.cert_file.empty() != settings_.key_file.empty())
        throw std::runtime_error("a TLS client certificate needs both cert_file and key_file");
      const char* ca = settings_.ca_file.empty() ? nullptr : settings_.ca_file.c_str();
      check(mosquitto_tls_set(mosq_, ca, ca == nullptr ? "/etc/ssl/certs" : nullptr,
                              settings_.cert_file.empty() ? nullptr : settings_.cert_file.c_str(),
                              settings_.key_file.empty() ? nullptr : settings_.key_file.c_str(), nullptr),
            "TLS settings (ca_file " + settings_.ca_file + ", cert_file " + settings_.cert_file + ")");
    }
    if (settings_.will) {
      const auto& w = *settings_.will;
      check(mosquitto_will_set_v5(mosq_, w.topic.c_str(), static_cast<int>(w.payload.size()), w.payload.data(), 1,
                                  w.retain, nullptr),
            "will on " + w.topic);
    }
  } catch (...) {
    mosquitto_destroy(mosq_);
    close(wake_fd_);
    throw;
  }
  mosquitto_connect_v5_callback_set(mosq_, [](mosquitto*, void* obj, int rc, int, const mosquitto_property*) {
    auto& cb = callbacks_of(obj);
    if (cb.connected) cb.connected(rc, rc == 0 ? "" : mosquitto_reason_string(rc));
  });
  mosquitto_disconnect_v5_callback_set(mosq_, [](mosquitto*, void* obj, int rc, const mosquitto_property*) {
    auto& cb = callbacks_of(obj);
    // rc is a MOSQ_ERR_* code, or a v5 reason code the broker sent with its DISCONNECT (>= 0x80).
    if (cb.disconnected)
      cb.disconnected(rc == 0 ? "disconnected" : rc >= 0x80 ? mosquitto_reason_string(rc) : mosquitto_error_text(rc));
  });
  mosquitto_publish_v5_callback_set(mosq_, [](mosquitto*, void* obj, int mid, int reason, const mosquitto_property*) {
    auto& cb = callbacks_of(obj);
    if (cb.published) cb.published(mid, reason);
  });
  mosquitto_message_v5_callback_set(
      mosq_, [](mosquitto*, void* obj, const mosquitto_message* m, const mosquitto_property* props) {
        auto& cb = callbacks_of(obj);
        if (!cb.message) return;
        std::string produced;
        bool skip_first = false;
        for (const mosquitto_property* p = props; p != nullptr; skip_first = true) {
          char* name = nullptr;
          char* value = nullptr;
          p = mosquitto_property_read_string_pair(p, MQTT_PROP_USER_PROPERTY, &name, &value, skip_first);
          if (p != nullptr && name != nullptr && std::string_view(name) == "produced_utc" && value != nullptr)
            produced = value;
          free(name);  // NOLINT: libmosquitto allocates them with malloc
          free(value);
        }
        cb.message(m->topic,
                   std::string_view(static_cast<const char*>(m->payload), static_cast<std::size_t>(m->payloadlen)),
                   produced);
      });
}

MqttConnection::~MqttConnection() {
  if (started_) mosquitto_disconnect_v5(mosq_, 0, nullptr);
  mosquitto_destroy(mosq_);
  close(wake_fd_);
}

std::string MqttConnection::connect() {
  int rc = MOSQ_ERR_SUCCESS;
  if (settings_.session_expiry_s > 0) {
    mosquitto_property* props = nullptr;
    mosquitto_property_add_int32(&props, MQTT_PROP_SESSION_EXPIRY_INTERVAL, settings_.session_expiry_s);
    rc = started_ ? mosquitto_reconnect(mosq_)
                  : mosquitto_connect_bind_v5(mosq_, settings_.broker.host.c_str(), settings_.broker.port,
                                              settings_.keepalive_s, nullptr, props);
    mosquitto_property_free_all(&props);
  } else {
    rc = started_ ? mosquitto_reconnect_async(mosq_)
                  : mosquitto_connect_async(mosq_, settings_.broker.host.c_str(), settings_.broker.port,
                                            settings_.keepalive_s);
  }
  started_ = true;
  return rc == MOSQ_ERR_SUCCESS ? std::string() : mosquitto_error_text(rc);
}

std::string MqttConnection::loop(int timeout_ms) {
  // The wait is ours, so that wake() ends it: a handed-over message goes out at once instead of after
  // mosquitto_loop()'s timeout. Then mosquitto_loop() without waiting does what is ready (TLS included).
  const int sock = mosquitto_socket(mosq_);
  if (sock >= 0) {
    pollfd fds[2] = {{sock, static_cast<short>(POLLIN | (mosquitto_want_write(mosq_) ? POLLOUT : 0)), 0},
                     {wake_fd_, POLLIN, 0}};
    if (poll(fds, 2, timeout_ms) > 0 && (fds[1].revents & POLLIN) != 0) {
      std::uint64_t count = 0;
      [[maybe_unused]] const auto ignored = read(wake_fd_, &count, sizeof(count));
    }
  }
  const int rc = mosquitto_loop(mosq_, 0, 1);
  return rc == MOSQ_ERR_SUCCESS ? std::string() : mosquitto_error_text(rc);
}

void MqttConnection::wake() noexcept {
  const std::uint64_t one = 1;
  [[maybe_unused]] const auto ignored = write(wake_fd_, &one, sizeof(one));
}

int MqttConnection::publish(const std::string& topic, std::string_view payload, int qos, bool retain,
                            std::string_view produced_utc, std::string& error) {
  mosquitto_property* props = nullptr;
  if (!produced_utc.empty()) {
    mosquitto_property_add_string_pair(&props, MQTT_PROP_USER_PROPERTY, "produced_utc",
                                       std::string(produced_utc).c_str());
  }
  int mid = -1;
  const int rc = mosquitto_publish_v5(mosq_, &mid, topic.c_str(), static_cast<int>(payload.size()), payload.data(), qos,
                                      retain, props);
  mosquitto_property_free_all(&props);
  if (rc != MOSQ_ERR_SUCCESS) {
    error = mosquitto_error_text(rc);
    const bool never = rc == MOSQ_ERR_PAYLOAD_SIZE || rc == MOSQ_ERR_OVERSIZE_PACKET || rc == MOSQ_ERR_MALFORMED_UTF8 ||
                       rc == MOSQ_ERR_INVAL || rc == MOSQ_ERR_QOS_NOT_SUPPORTED ||
                       rc == MOSQ_ERR_RETAIN_NOT_SUPPORTED || rc == MOSQ_ERR_TOPIC_ALIAS_INVALID;
    return never ? never_sendable : -1;
  }
  return mid;
}

bool MqttConnection::subscribe(const std::string& filter, int qos, std::string& error) {
  const int rc = mosquitto_subscribe_v5(mosq_, nullptr, filter.c_str(), qos, 0, nullptr);
  if (rc != MOSQ_ERR_SUCCESS) error = mosquitto_error_text(rc);
  return rc == MOSQ_ERR_SUCCESS;
}

void MqttConnection::disconnect() {
  if (started_) mosquitto_disconnect_v5(mosq_, 0, nullptr);
}

}  // namespace guideway::plant
