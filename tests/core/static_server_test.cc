#include "src/core/static_server.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <string>

#include <gtest/gtest.h>

#include "src/core/error.h"
#include "tests/support/test_files.h"

namespace pano4d {
namespace {
namespace fs = std::filesystem;

// One request on a fresh connection; the whole response.
std::string Request(int port, const std::string& request) {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  address.sin_port = htons(port);
  EXPECT_EQ(connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof(address)),
            0);
  send(fd, request.data(), request.size(), 0);
  std::string response;
  char buffer[4096];
  for (ssize_t n; (n = recv(fd, buffer, sizeof(buffer), 0)) > 0;)
    response.append(buffer, n);
  close(fd);
  return response;
}

TEST(StaticServerTest, ServesFilesWithTheirTypesAndNothingOutsideTheRoot) {
  testing::TempDir dir;
  fs::create_directories(dir / "site/lib");
  testing::WriteText(dir / "site/index.html", "<p>hi</p>");
  testing::WriteText(dir / "site/lib/a.js", "export const a = 1;");
  testing::WriteText(dir / "secret.txt", "SECRET");
  StaticServer server(dir / "site", 0);
  server.ServeInBackground();
  const std::string index = Request(server.port(), "GET / HTTP/1.1\r\n\r\n");
  EXPECT_NE(index.find("200 OK"), std::string::npos) << index;
  EXPECT_NE(index.find("text/html"), std::string::npos);
  EXPECT_NE(index.find("<p>hi</p>"), std::string::npos);
  const std::string js =
      Request(server.port(), "GET /lib/a.js?v=2 HTTP/1.1\r\n\r\n");
  EXPECT_NE(js.find("text/javascript"), std::string::npos) << js;
  EXPECT_NE(js.find("export const a"), std::string::npos);
  for (const char* target : {"/../secret.txt", "/%2e%2e/secret.txt",
                             "/lib/../../secret.txt", "/missing.js"}) {
    const std::string r = Request(
        server.port(), std::string("GET ") + target + " HTTP/1.1\r\n\r\n");
    EXPECT_NE(r.find("404"), std::string::npos) << target << ": " << r;
    EXPECT_EQ(r.find("SECRET"), std::string::npos) << target;
  }
  server.Stop();
}

// A hostile page in the user's browser can send any request to 127.0.0.1:
// no request may read outside the served folder or end the process.
TEST(StaticServerTest, SymlinksOutOfTheRootAndUnresolvablePathsAreNotFound) {
  testing::TempDir dir;
  fs::create_directories(dir / "site/sub");
  testing::WriteText(dir / "site/index.html", "<p>hi</p>");
  testing::WriteText(dir / "site/sub/in.txt", "INSIDE");
  testing::WriteText(dir / "secret.txt", "SECRET");
  fs::create_symlink(dir / "secret.txt", dir / "site/pw.txt");
  fs::create_directory_symlink(dir.path(), dir / "site/up");
  fs::create_directory_symlink("/", dir / "site/r");
  fs::create_symlink(dir / "site/loop_b", dir / "site/loop_a");
  fs::create_symlink(dir / "site/loop_a", dir / "site/loop_b");
  fs::create_symlink(dir / "site/sub/in.txt", dir / "site/link_in.txt");
  StaticServer server(dir / "site", 0);
  server.ServeInBackground();
  const std::string long_name(256, 'a');
  std::string long_path;
  while (long_path.size() <= 4096) long_path += "/" + std::string(200, 'b');
  for (const std::string& target :
       {std::string("/pw.txt"), std::string("/up/secret.txt"),
        std::string("/r/etc/passwd"), std::string("/loop_a"),
        std::string("/loop_a/x"), "/" + long_name, long_path}) {
    const std::string r =
        Request(server.port(), "GET " + target + " HTTP/1.1\r\n\r\n");
    EXPECT_NE(r.find("404"), std::string::npos)
        << target.substr(0, 40) << ": " << r.substr(0, 80);
    EXPECT_EQ(r.find("SECRET"), std::string::npos) << target;
    EXPECT_EQ(r.find("root:"), std::string::npos) << target;
  }
  // Still up, and a link to a file inside the root is served.
  const std::string in =
      Request(server.port(), "GET /link_in.txt HTTP/1.1\r\n\r\n");
  EXPECT_NE(in.find("INSIDE"), std::string::npos) << in;
  const std::string index = Request(server.port(), "GET / HTTP/1.1\r\n\r\n");
  EXPECT_NE(index.find("<p>hi</p>"), std::string::npos) << index;
  server.Stop();
}

TEST(StaticServerTest, PostsGoToTheHandlerWithTheirBody) {
  testing::TempDir dir;
  testing::WriteText(dir / "index.html", "x");
  std::string got_path, got_body;
  StaticServer server(dir.path(), 0,
                      [&](const std::string& path, const std::string& body) {
                        got_path = path;
                        got_body = body;
                        return path == "/capture/a.png";
                      });
  server.ServeInBackground();
  const std::string body(100000, 'b');
  const std::string ok = Request(
      server.port(), "POST /capture/a.png HTTP/1.1\r\nContent-Length: " +
                         std::to_string(body.size()) + "\r\n\r\n" + body);
  EXPECT_NE(ok.find("200 OK"), std::string::npos) << ok;
  EXPECT_EQ(got_path, "/capture/a.png");
  EXPECT_EQ(got_body, body);
  const std::string refused = Request(
      server.port(), "POST /other HTTP/1.1\r\nContent-Length: 1\r\n\r\nz");
  EXPECT_NE(refused.find("404"), std::string::npos);
  server.Stop();
}

TEST(StaticServerTest, ATakenPortIsAnErrorNamingIt) {
  testing::TempDir dir;
  StaticServer first(dir.path(), 0);
  try {
    StaticServer second(dir.path(), first.port());
    FAIL() << "two servers on one port";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(std::to_string(first.port())),
              std::string::npos)
        << e.what();
  }
}

TEST(StaticServerTest, ContentTypes) {
  EXPECT_EQ(ContentTypeFor("a.json"), "application/json");
  EXPECT_EQ(ContentTypeFor("scene4d.bin"), "application/octet-stream");
  EXPECT_EQ(ContentTypeFor("x.png"), "image/png");
}

}  // namespace
}  // namespace pano4d
