#include "src/core/static_server.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <map>
#include <sstream>

#include "src/core/error.h"
#include "src/core/file.h"

namespace pano4d {
namespace fs = std::filesystem;
namespace {

// How long Serve() waits for a connection before looking at the stop flag.
constexpr int kPollMilliseconds = 100;
// A connection that sends nothing for this long is closed (browsers open
// spare connections they may never use).
constexpr int kReceiveTimeoutSeconds = 5;
// Requests larger than this are refused (screenshots are far smaller).
constexpr std::size_t kMaxRequestBytes = 64u << 20;

void SendAll(int fd, const std::string& bytes) {
  std::size_t sent = 0;
  while (sent < bytes.size()) {
    const ssize_t n =
        send(fd, bytes.data() + sent, bytes.size() - sent, MSG_NOSIGNAL);
    if (n <= 0) return;  // the client went away
    sent += static_cast<std::size_t>(n);
  }
}

void Reply(int fd, int status, const std::string& reason,
           const std::string& type, const std::string& body,
           bool head = false) {
  std::ostringstream out;
  out << "HTTP/1.1 " << status << " " << reason << "\r\n"
      << "Content-Type: " << type << "\r\n"
      << "Content-Length: " << body.size() << "\r\n"
      << "Cache-Control: no-cache\r\n"
      << "Connection: close\r\n\r\n";
  SendAll(fd, out.str() + (head ? std::string() : body));
}

// Whether the canonical path `file` lies in the canonical folder `root`.
bool IsInside(const fs::path& file, const fs::path& root) {
  auto f = file.begin();
  for (auto r = root.begin(); r != root.end(); ++r, ++f) {
    if (r->empty()) continue;  // a trailing separator
    if (f == file.end() || *f != *r) return false;
  }
  return true;
}

int HexValue(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

}  // namespace

std::string ContentTypeFor(const fs::path& file) {
  static const std::map<std::string, std::string> kTypes = {
      {".html", "text/html; charset=utf-8"},
      {".js", "text/javascript; charset=utf-8"},
      {".mjs", "text/javascript; charset=utf-8"},
      {".json", "application/json"},
      {".map", "application/json"},
      {".css", "text/css"},
      {".png", "image/png"},
      {".txt", "text/plain; charset=utf-8"},
      {".ply", "application/octet-stream"},
      {".bin", "application/octet-stream"}};
  const auto found = kTypes.find(file.extension().string());
  return found != kTypes.end() ? found->second : "application/octet-stream";
}

fs::path ResolveRequestPath(const fs::path& root, const std::string& target) {
  std::string path = target.substr(0, target.find_first_of("?#"));
  if (path.empty() || path[0] != '/') return {};
  std::string decoded;
  for (std::size_t i = 0; i < path.size(); ++i) {
    if (path[i] == '%') {
      if (i + 2 >= path.size()) return {};
      const int hi = HexValue(path[i + 1]), lo = HexValue(path[i + 2]);
      if (hi < 0 || lo < 0) return {};
      decoded += static_cast<char>(hi * 16 + lo);
      i += 2;
    } else {
      decoded += path[i];
    }
  }
  if (decoded.find('\0') != std::string::npos) return {};
  fs::path relative;
  std::stringstream parts(decoded);
  for (std::string part; std::getline(parts, part, '/');) {
    if (part.empty() || part == ".") continue;
    if (part == "..") return {};
    relative /= part;
  }
  // Symbolic links are followed, but only to files inside the root; a
  // name too long, a link loop or any other failure is "not found".
  std::error_code error;
  const fs::path real_root = fs::canonical(root, error);
  if (error) return {};
  fs::path file = fs::canonical(real_root / relative, error);
  if (error) return {};
  if (fs::is_directory(file, error))
    file = fs::canonical(file / "index.html", error);
  if (error || !IsInside(file, real_root) ||
      !fs::is_regular_file(file, error) || error)
    return {};
  return file;
}

StaticServer::StaticServer(fs::path root, int port, PostHandler on_post)
    : root_(std::move(root)), on_post_(std::move(on_post)) {
  if (!fs::is_directory(root_))
    throw Error::In(root_.string(), "is not a folder to serve");
  listener_ = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (listener_ < 0)
    throw Error::In("serve", std::string("socket: ") + std::strerror(errno));
  const int yes = 1;
  setsockopt(listener_, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof(yes));
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  address.sin_port = htons(static_cast<std::uint16_t>(port));
  if (bind(listener_, reinterpret_cast<sockaddr*>(&address), sizeof(address)) !=
          0 ||
      listen(listener_, 64) != 0) {
    const std::string why = std::strerror(errno);
    close(listener_);
    throw Error("--serve", "", std::to_string(port),
                "cannot listen on 127.0.0.1:" + std::to_string(port) + " (" +
                    why + "); choose another port, or 0 for any free one");
  }
  socklen_t length = sizeof(address);
  getsockname(listener_, reinterpret_cast<sockaddr*>(&address), &length);
  port_ = ntohs(address.sin_port);
}

StaticServer::~StaticServer() {
  Stop();
  if (listener_ >= 0) close(listener_);
}

std::string StaticServer::url() const {
  return "http://127.0.0.1:" + std::to_string(port_) + "/";
}

void StaticServer::Serve() {
  while (!stop_) {
    pollfd p{listener_, POLLIN, 0};
    if (poll(&p, 1, kPollMilliseconds) <= 0) continue;
    const int connection = accept4(listener_, nullptr, nullptr, SOCK_CLOEXEC);
    if (connection < 0) continue;
    timeval timeout{kReceiveTimeoutSeconds, 0};
    setsockopt(connection, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof(timeout));
    ++open_;
    std::thread([this, connection] {
      // Nothing a request does may end the process: any failure answers
      // this connection alone.
      try {
        Answer(connection);
      } catch (...) {
        try {
          Reply(connection, 500, "Internal Server Error", "text/plain",
                "internal error\n");
        } catch (...) {
        }
      }
      close(connection);
      --open_;
    }).detach();
  }
}

void StaticServer::ServeInBackground() {
  background_ = std::thread([this] { Serve(); });
}

void StaticServer::Stop() {
  stop_ = true;
  if (background_.joinable()) background_.join();
  // Connections end within kReceiveTimeoutSeconds of their last byte.
  while (open_ > 0) std::this_thread::sleep_for(std::chrono::milliseconds(10));
}

void StaticServer::Answer(int fd) {
  // The request line and headers, then the body of a POST.
  std::string request;
  std::size_t header_end = std::string::npos;
  char buffer[65536];
  while (header_end == std::string::npos) {
    const ssize_t n = recv(fd, buffer, sizeof(buffer), 0);
    if (n <= 0) return;
    request.append(buffer, n);
    if (request.size() > kMaxRequestBytes) return;
    header_end = request.find("\r\n\r\n");
  }
  std::istringstream head(request.substr(0, header_end));
  std::string method, target, version;
  head >> method >> target >> version;
  std::size_t content_length = 0;
  for (std::string line; std::getline(head, line);) {
    std::string lower = line;
    for (char& c : lower) c = static_cast<char>(std::tolower(c));
    if (lower.rfind("content-length:", 0) == 0)
      content_length = std::strtoull(line.c_str() + 15, nullptr, 10);
  }
  if (method == "POST") {
    if (content_length > kMaxRequestBytes)
      return Reply(fd, 413, "Payload Too Large", "text/plain", "too large\n");
    std::string body = request.substr(header_end + 4);
    while (body.size() < content_length) {
      const ssize_t n = recv(fd, buffer, sizeof(buffer), 0);
      if (n <= 0) return;
      body.append(buffer, n);
    }
    body.resize(content_length);
    const std::string path = target.substr(0, target.find('?'));
    const bool ok = on_post_ && on_post_(path, body);
    return ok ? Reply(fd, 200, "OK", "text/plain", "ok\n")
              : Reply(fd, 404, "Not Found", "text/plain", "no handler\n");
  }
  if (method != "GET" && method != "HEAD")
    return Reply(fd, 405, "Method Not Allowed", "text/plain", "GET only\n");
  const fs::path file = ResolveRequestPath(root_, target);
  if (file.empty())
    return Reply(fd, 404, "Not Found", "text/plain", "not found\n");
  std::string body;
  try {
    body = ReadTextFile(file);
  } catch (const Error&) {
    return Reply(fd, 500, "Internal Server Error", "text/plain",
                 "unreadable\n");
  }
  Reply(fd, 200, "OK", ContentTypeFor(file), body, method == "HEAD");
}

}  // namespace pano4d
