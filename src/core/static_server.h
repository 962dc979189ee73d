#pragma once

// A static file server on localhost, for `pano4d view --serve` (browsers
// refuse ES modules and fetch() from file:// pages). GET and HEAD serve
// files under the root; POST goes to an optional handler (the browser
// test receives its screenshots that way). Each connection is answered on
// its own thread and closed after one response.

#include <atomic>
#include <filesystem>
#include <functional>
#include <string>
#include <thread>

namespace pano4d {

class StaticServer {
 public:
  // The handler of POST requests: the path (without the query) and the
  // body; true answers 200, false 404.
  using PostHandler =
      std::function<bool(const std::string& path, const std::string& body)>;

  // Listens on 127.0.0.1:`port` (0: a free port the system picks). Throws
  // pano4d::Error naming the port when it is taken, and the root when it
  // is not a folder.
  StaticServer(std::filesystem::path root, int port,
               PostHandler on_post = nullptr);
  ~StaticServer();  // Stop()
  StaticServer(const StaticServer&) = delete;
  StaticServer& operator=(const StaticServer&) = delete;

  int port() const { return port_; }
  std::string url() const;  // http://127.0.0.1:PORT/

  // Answers requests until Stop() (from another thread or a signal
  // handler's flag).
  void Serve();
  // Starts Serve() on a thread of its own (for tests).
  void ServeInBackground();
  // Ends Serve() within a poll interval and waits for open connections.
  void Stop();

 private:
  void Answer(int connection);

  std::filesystem::path root_;
  PostHandler on_post_;
  int listener_ = -1;
  int port_ = 0;
  std::atomic<bool> stop_{false};
  std::thread background_;
  std::atomic<int> open_{0};  // connections being answered
};

// The Content-Type of a file served by name ("text/javascript" for .js:
// browsers load ES modules only with a JavaScript type).
std::string ContentTypeFor(const std::filesystem::path& file);

// The file under `root` that the request path names ("/" is index.html),
// canonical, or an empty path for a path that leaves the root (.., or a
// symbolic link to outside it), is not a regular file, cannot be resolved
// (a name over the system's limit, a link loop) or is malformed. %XX
// escapes are decoded; the query is ignored.
std::filesystem::path ResolveRequestPath(const std::filesystem::path& root,
                                         const std::string& target);

}  // namespace pano4d
