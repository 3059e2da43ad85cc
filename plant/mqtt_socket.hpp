#pragma once
// A client's byte stream to an MQTT broker: TCP, or TLS over TCP (OpenSSL) for mqtts://, with every
// wait bounded. Used by the fleet's own MQTT client (plant/mqtt_inbox.hpp). Not thread safe.

#include <atomic>
#include <stdexcept>
#include <string>
#include <string_view>

#include "plant/mqtt_connection.hpp"

struct ssl_ctx_st;
struct ssl_st;

namespace guideway::plant {

// Thrown by a wait of MqttSocket once its stop flag is set.
class SocketStopped : public std::runtime_error {
 public:
  SocketStopped() : std::runtime_error("stopped") {}
};

class MqttSocket {
 public:
  // Connects to settings.broker (and completes the TLS handshake, verifying the broker's certificate
  // against ca_file, or the system's CAs, and its name or address) within timeout_ms. Throws
  // std::runtime_error saying why not ("connection refused", "certificate verify failed", ...). Every
  // wait of this socket also ends within 100 ms of `stop` being set (a SIGTERM while a broker says
  // nothing), throwing SocketStopped.
  MqttSocket(const ConnectionSettings& settings, int timeout_ms, const std::atomic<bool>* stop = nullptr);
  ~MqttSocket();
  MqttSocket(const MqttSocket&) = delete;
  MqttSocket& operator=(const MqttSocket&) = delete;

  // Writes all of `bytes` within timeout_ms, or throws.
  void write_all(std::string_view bytes, int timeout_ms);
  // What has arrived, waiting up to timeout_ms for the first byte: "" when nothing came in time.
  // Throws std::runtime_error when the broker closed the connection or it failed.
  std::string read_some(int timeout_ms);

 private:
  int fd_ = -1;
  const std::atomic<bool>* stop_ = nullptr;
  ssl_ctx_st* ctx_ = nullptr;
  ssl_st* ssl_ = nullptr;
};

// Why a TLS file cannot be used ("" when it can): not readable, a directory, or not PEM holding what it
// must (a certificate for ca_file and cert_file, a private key for key_file). For --check-config and the
// fleet's options, so that a broken file is found before run time.
enum class TlsFileRole { ca_certificates, client_certificate, private_key };
std::string tls_file_problem(const std::string& path, TlsFileRole role);

}  // namespace guideway::plant
