// A client's byte stream to an MQTT broker, TCP or TLS (mqtt_socket.hpp).
#include "plant/mqtt_socket.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <unistd.h>

#include <openssl/err.h>
#include <openssl/pem.h>
#include <openssl/ssl.h>
#include <openssl/x509v3.h>

#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <memory>
#include <stdexcept>

namespace guideway::plant {

namespace {

using Clock = std::chrono::steady_clock;

int ms_left(Clock::time_point deadline) {
  const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
  return left > 0 ? static_cast<int>(left) : 0;
}

constexpr int stop_check_ms = 100;  // a stop flag is looked at this often while a wait lasts

// True when fd became ready for `events` before the deadline. Throws SocketStopped once *stop is set.
bool wait_ready(int fd, short events, Clock::time_point deadline, const std::atomic<bool>* stop) {
  for (;;) {
    if (stop != nullptr && stop->load()) throw SocketStopped();
    pollfd p{fd, events, 0};
    const int left = ms_left(deadline);
    const int n = poll(&p, 1, stop != nullptr ? std::min(left, stop_check_ms) : left);
    if (n > 0) return true;
    if (n == 0) {
      if (ms_left(deadline) == 0) return false;
      continue;
    }
    if (errno != EINTR) throw std::runtime_error(std::string("poll: ") + std::strerror(errno));
  }
}

// OpenSSL's queued errors as one clause ("certificate verify failed"), and clears them.
std::string tls_errors() {
  std::string out;
  while (const unsigned long e = ERR_get_error()) {
    const char* reason = ERR_reason_error_string(e);
    if (!out.empty()) out += "; ";
    out += reason != nullptr ? reason : "error " + std::to_string(e);
  }
  return out.empty() ? "TLS error" : out;
}

int connect_tcp(const BrokerAddress& broker, Clock::time_point deadline, const std::atomic<bool>* stop) {
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  addrinfo* found = nullptr;
  const std::string port = std::to_string(broker.port);
  if (const int rc = getaddrinfo(broker.host.c_str(), port.c_str(), &hints, &found); rc != 0)
    throw std::runtime_error("cannot resolve " + broker.host + ": " + gai_strerror(rc));
  std::unique_ptr<addrinfo, decltype(&freeaddrinfo)> list(found, freeaddrinfo);
  std::string why = "no address";
  for (const addrinfo* a = found; a != nullptr; a = a->ai_next) {
    const int fd = socket(a->ai_family, a->ai_socktype | SOCK_NONBLOCK | SOCK_CLOEXEC, a->ai_protocol);
    if (fd < 0) {
      why = std::strerror(errno);
      continue;
    }
    int rc = connect(fd, a->ai_addr, a->ai_addrlen);
    if (rc != 0 && errno == EINPROGRESS) {
      bool ready = false;
      try {
        ready = wait_ready(fd, POLLOUT, deadline, stop);
      } catch (...) {
        close(fd);
        throw;
      }
      if (!ready) {
        close(fd);
        why = "timed out";
        continue;
      }
      int err = 0;
      socklen_t len = sizeof(err);
      getsockopt(fd, SOL_SOCKET, SO_ERROR, &err, &len);
      rc = err == 0 ? 0 : -1;
      errno = err;
    }
    if (rc == 0) {
      const int one = 1;
      setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof(one));
      return fd;
    }
    why = std::strerror(errno);
    close(fd);
  }
  throw std::runtime_error("cannot connect to " + broker.url() + ": " + why);
}

// Repeats an OpenSSL call while it wants the network, within the deadline; its result when done.
template <typename Call>
int tls_call(ssl_st* ssl, int fd, Clock::time_point deadline, const std::atomic<bool>* stop, const char* what,
             Call call) {
  for (;;) {
    ERR_clear_error();
    const int rc = call();
    if (rc > 0) return rc;
    const int err = SSL_get_error(ssl, rc);
    if (err == SSL_ERROR_WANT_READ || err == SSL_ERROR_WANT_WRITE) {
      if (!wait_ready(fd, err == SSL_ERROR_WANT_READ ? POLLIN : POLLOUT, deadline, stop)) return 0;
      continue;
    }
    if (err == SSL_ERROR_ZERO_RETURN) throw std::runtime_error("the broker closed the connection");
    if (err == SSL_ERROR_SYSCALL && ERR_peek_error() == 0)
      throw std::runtime_error(std::string(what) + ": " + (errno != 0 ? std::strerror(errno) : "connection closed"));
    std::string why = tls_errors();
    const long verify = SSL_get_verify_result(ssl);
    if (verify != X509_V_OK) why += " (" + std::string(X509_verify_cert_error_string(verify)) + ")";
    throw std::runtime_error(std::string(what) + ": " + why);
  }
}

bool is_ip_literal(const std::string& host) {
  in6_addr a6{};
  in_addr a4{};
  return inet_pton(AF_INET, host.c_str(), &a4) == 1 || inet_pton(AF_INET6, host.c_str(), &a6) == 1;
}

}  // namespace

MqttSocket::MqttSocket(const ConnectionSettings& s, int timeout_ms, const std::atomic<bool>* stop) : stop_(stop) {
  const auto deadline = Clock::now() + std::chrono::milliseconds(timeout_ms);
  fd_ = connect_tcp(s.broker, deadline, stop_);
  if (!s.broker.tls) return;
  try {
    ctx_ = SSL_CTX_new(TLS_client_method());
    if (ctx_ == nullptr) throw std::runtime_error("TLS: " + tls_errors());
    SSL_CTX_set_min_proto_version(ctx_, TLS1_2_VERSION);
    SSL_CTX_set_verify(ctx_, SSL_VERIFY_PEER, nullptr);
    const bool loaded = s.ca_file.empty() ? SSL_CTX_set_default_verify_paths(ctx_) == 1
                                          : SSL_CTX_load_verify_locations(ctx_, s.ca_file.c_str(), nullptr) == 1;
    if (!loaded) throw std::runtime_error("TLS: cannot load the CA certificates " + s.ca_file + ": " + tls_errors());
    if (!s.cert_file.empty()) {
      if (SSL_CTX_use_certificate_chain_file(ctx_, s.cert_file.c_str()) != 1)
        throw std::runtime_error("TLS: cannot load the client certificate " + s.cert_file + ": " + tls_errors());
      if (SSL_CTX_use_PrivateKey_file(ctx_, s.key_file.c_str(), SSL_FILETYPE_PEM) != 1 ||
          SSL_CTX_check_private_key(ctx_) != 1)
        throw std::runtime_error("TLS: cannot use the key " + s.key_file + ": " + tls_errors());
    }
    ssl_ = SSL_new(ctx_);
    if (ssl_ == nullptr || SSL_set_fd(ssl_, fd_) != 1) throw std::runtime_error("TLS: " + tls_errors());
    // The broker must be the one named: its certificate's DNS name, or its IP address for a literal.
    X509_VERIFY_PARAM* param = SSL_get0_param(ssl_);
    if (is_ip_literal(s.broker.host)) {
      X509_VERIFY_PARAM_set1_ip_asc(param, s.broker.host.c_str());
    } else {
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wold-style-cast"             // OpenSSL's macro
      SSL_set_tlsext_host_name(ssl_, s.broker.host.c_str());  // SNI
#pragma GCC diagnostic pop
      SSL_set1_host(ssl_, s.broker.host.c_str());
    }
    if (tls_call(ssl_, fd_, deadline, stop_, "TLS handshake", [&] { return SSL_connect(ssl_); }) == 0)
      throw std::runtime_error("TLS handshake with " + s.broker.url() + ": timed out");
  } catch (...) {
    SSL_free(ssl_);
    SSL_CTX_free(ctx_);
    close(fd_);
    throw;
  }
}

MqttSocket::~MqttSocket() {
  if (ssl_ != nullptr) SSL_shutdown(ssl_);  // best effort close_notify: the socket is non-blocking
  SSL_free(ssl_);
  SSL_CTX_free(ctx_);
  close(fd_);
}

void MqttSocket::write_all(std::string_view bytes, int timeout_ms) {
  const auto deadline = Clock::now() + std::chrono::milliseconds(timeout_ms);
  while (!bytes.empty()) {
    std::size_t n = 0;
    if (ssl_ != nullptr) {
      const int rc = tls_call(ssl_, fd_, deadline, stop_, "TLS write", [&] {
        return SSL_write(ssl_, bytes.data(), static_cast<int>(std::min<std::size_t>(bytes.size(), 1 << 30)));
      });
      if (rc == 0) throw std::runtime_error("writing to the broker timed out");
      n = static_cast<std::size_t>(rc);
    } else {
      const ssize_t rc = send(fd_, bytes.data(), bytes.size(), MSG_NOSIGNAL);
      if (rc < 0) {
        if (errno == EINTR) continue;
        if (errno != EAGAIN) throw std::runtime_error(std::string("writing to the broker: ") + std::strerror(errno));
        if (!wait_ready(fd_, POLLOUT, deadline, stop_)) throw std::runtime_error("writing to the broker timed out");
        continue;
      }
      n = static_cast<std::size_t>(rc);
    }
    bytes.remove_prefix(n);
  }
}

std::string MqttSocket::read_some(int timeout_ms) {
  const auto deadline = Clock::now() + std::chrono::milliseconds(timeout_ms);
  char buffer[16384];
  if (ssl_ != nullptr) {
    const int rc =
        tls_call(ssl_, fd_, deadline, stop_, "TLS read", [&] { return SSL_read(ssl_, buffer, sizeof(buffer)); });
    return std::string(buffer, static_cast<std::size_t>(rc));  // rc 0: timed out, nothing read
  }
  for (;;) {
    const ssize_t rc = recv(fd_, buffer, sizeof(buffer), 0);
    if (rc > 0) return std::string(buffer, static_cast<std::size_t>(rc));
    if (rc == 0) throw std::runtime_error("the broker closed the connection");
    if (errno == EINTR) continue;
    if (errno != EAGAIN) throw std::runtime_error(std::string("reading from the broker: ") + std::strerror(errno));
    if (!wait_ready(fd_, POLLIN, deadline, stop_)) return {};
  }
}

std::string tls_file_problem(const std::string& path, TlsFileRole role) {
  struct stat st {};
  if (stat(path.c_str(), &st) != 0) return "cannot read " + path + ": " + std::strerror(errno);
  if (S_ISDIR(st.st_mode)) return path + " is a directory, not a PEM file";
  if (!S_ISREG(st.st_mode)) return path + " is not a regular file, not a PEM file";
  std::unique_ptr<FILE, decltype(&fclose)> f(std::fopen(path.c_str(), "r"), fclose);
  if (!f) return "cannot read " + path + ": " + std::strerror(errno);
  if (role == TlsFileRole::private_key) {
    EVP_PKEY* key = PEM_read_PrivateKey(f.get(), nullptr, nullptr, nullptr);
    ERR_clear_error();
    if (key == nullptr)
      return path + " holds no PEM private key (or it is encrypted: a service cannot type a passphrase)";
    EVP_PKEY_free(key);
    return {};
  }
  X509* cert = PEM_read_X509(f.get(), nullptr, nullptr, nullptr);
  ERR_clear_error();
  if (cert == nullptr)
    return path + " holds no PEM certificate (-----BEGIN CERTIFICATE-----)" +
           (role == TlsFileRole::ca_certificates ? ": ca_file names the CA certificate that signed the broker's" : "");
  X509_free(cert);
  return {};
}

}  // namespace guideway::plant
