#include "apps/view/view_server.h"

#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <httplib.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <thread>

#include "common/testing/process.h"

namespace rumi {
namespace {

// Any free port on loopback; few streams with short queues (the limits are tested).
ViewOptions Loopback(int max_clients = 3, int client_queue = 8) {
  ViewOptions o;
  o.port = 0;
  o.max_clients = max_clients;
  o.client_queue = client_queue;
  return o;
}

struct Served {
  std::shared_ptr<ViewHub> hub;
  std::unique_ptr<ViewServer> server;
  Served(const ViewOptions& o, const std::string& token) : hub(std::make_shared<ViewHub>(o)) {
    std::string why;
    server = ViewServer::Start(o, token, hub, FindWebDir(""), &why);
    EXPECT_TRUE(server) << why;
  }
  httplib::Client Client() const { return httplib::Client("127.0.0.1", server->port()); }
};

// A live stream over a plain socket: a browser that reads (or does not).
int OpenStream(int port, bool stalled = false) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(static_cast<uint16_t>(port));
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  const int small = 4096;  // a stalled reader fills its buffers quickly
  if (stalled) ::setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &small, sizeof(small));
  EXPECT_EQ(::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof(a)), 0);
  const std::string req = "GET /api/events HTTP/1.1\r\nHost: x\r\n\r\n";
  EXPECT_EQ(::send(fd, req.data(), req.size(), 0), static_cast<ssize_t>(req.size()));
  return fd;
}

// Reads from fd until `needle` arrived (true) or timeout_s passed.
bool ReadUntil(int fd, const std::string& needle, double timeout_s, std::string* seen = nullptr) {
  std::string got;
  timeval tv{0, 200000};
  ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof(tv));
  const auto t0 = std::chrono::steady_clock::now();
  char buf[4096];
  while (test::SecondsSince(t0) < timeout_s) {
    const ssize_t n = ::recv(fd, buf, sizeof(buf), 0);
    if (n > 0) got.append(buf, static_cast<size_t>(n));
    if (got.find(needle) != std::string::npos) break;
    if (n == 0) break;
  }
  if (seen) *seen = got;
  return got.find(needle) != std::string::npos;
}

TEST(TokenMatches, OnlyTheWholeToken) {
  EXPECT_TRUE(TokenMatches("s3cret-token", "s3cret-token"));
  EXPECT_FALSE(TokenMatches("s3cret-token", "s3cret-tokeN"));
  EXPECT_FALSE(TokenMatches("s3cret-token", "s3cret"));
  EXPECT_FALSE(TokenMatches("s3cret-token", ""));
  EXPECT_FALSE(TokenMatches("", ""));  // no token set never matches: the check is not made then
}

TEST(ClientQueue, AFullQueueDropsItsOldest) {
  ClientQueue q(3);
  for (int i = 0; i < 5; ++i) q.Push(std::to_string(i));
  EXPECT_EQ(q.size(), 3u);
  EXPECT_EQ(q.dropped(), 2);
  std::string m;
  ASSERT_TRUE(q.Pop(std::chrono::milliseconds(0), &m));
  EXPECT_EQ(m, "2");
  q.Close();
  q.Push("late");  // a closed queue takes nothing, and hands out what it held
  ASSERT_TRUE(q.Pop(std::chrono::milliseconds(0), &m));
  EXPECT_EQ(m, "3");
  ASSERT_TRUE(q.Pop(std::chrono::milliseconds(0), &m));
  EXPECT_EQ(m, "4");
  EXPECT_FALSE(q.Pop(std::chrono::milliseconds(0), &m));
  EXPECT_TRUE(q.closed());
}

TEST(ViewOptions, ANonLoopbackAddressNeedsAToken) {
  std::string why;
  ViewOptions o;
  EXPECT_TRUE(o.Check(&why)) << why;
  o.bind = "0.0.0.0";
  EXPECT_FALSE(o.Check(&why));
  EXPECT_NE(why.find("token"), std::string::npos) << why;
  o.token_file = "view.token";
  EXPECT_TRUE(o.Check());
  o.bind = "127.0.0.1; rm";
  EXPECT_FALSE(o.Check());
  EXPECT_TRUE(IsLoopbackAddress("127.0.0.1") && IsLoopbackAddress("::1") && !IsLoopbackAddress("10.0.0.1"));
}

TEST(ViewServer, ServesThePageAndItsJson) {
  Served s(Loopback(), "");
  ASSERT_TRUE(s.server);
  auto c = s.Client();
  auto r = c.Get("/");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200);
  EXPECT_NE(r->body.find("view.js"), std::string::npos);
  EXPECT_NE(r->get_header_value("Content-Security-Policy").find("'self'"), std::string::npos);
  for (const char* path : {"/view.js", "/view.css", "/api/map", "/api/state", "/api/grid", "/api/timeline", "/api/manager_stats"}) {
    r = c.Get(path);
    ASSERT_TRUE(r) << path;
    EXPECT_EQ(r->status, 200) << path;
  }
  EXPECT_TRUE(nlohmann::json::parse(c.Get("/api/map")->body).contains("cells_add"));
  EXPECT_FALSE(nlohmann::json::parse(c.Get("/api/grid")->body)["ok"].get<bool>());
  r = c.Get("/api/grid.pgm");
  EXPECT_EQ(r->status, 404);
  EXPECT_NE(r->body.find("no occupancy grid"), std::string::npos);
}

TEST(ViewServer, BadRequestsGet4xxWithAReason) {
  Served s(Loopback(), "");
  ASSERT_TRUE(s.server);
  auto c = s.Client();
  auto r = c.Get("/no-such-page");
  EXPECT_EQ(r->status, 404);
  EXPECT_NE(r->body.find("no such page"), std::string::npos);
  r = c.Get("/../etc/passwd");
  EXPECT_EQ(r->status, 400);
  r = c.Get("/view.js%00");
  EXPECT_EQ(r->status, 400);
  EXPECT_NE(r->body.find("character"), std::string::npos);
  r = c.Get("/" + std::string(300, 'a'));
  EXPECT_EQ(r->status, 414);
  r = c.Post("/api/map", "{}", "application/json");
  EXPECT_EQ(r->status, 405);
  EXPECT_NE(r->body.find("read-only"), std::string::npos);
  r = c.Delete("/api/map");
  EXPECT_EQ(r->status, 405);
}

TEST(ViewServer, ATokenIsCheckedOnEveryRequest) {
  Served s(Loopback(), "t0ken");
  ASSERT_TRUE(s.server);
  auto c = s.Client();
  for (const char* path : {"/", "/view.js", "/api/map", "/api/events"}) {
    auto r = c.Get(path);
    EXPECT_EQ(r->status, 401) << path;
    EXPECT_NE(r->body.find("token"), std::string::npos);
    r = c.Get(std::string(path) + "?token=t0keN");
    EXPECT_EQ(r->status, 403) << path;
  }
  EXPECT_EQ(c.Get("/api/map?token=t0ken")->status, 200);
  EXPECT_EQ(c.Get("/api/map", {{"Authorization", "Bearer t0ken"}})->status, 200);
}

TEST(ViewServer, ANonLoopbackBindWithoutATokenDoesNotStart) {
  ViewOptions o = Loopback();
  o.bind = "0.0.0.0";
  o.token = "x";  // the options pass...
  std::string why;
  auto hub = std::make_shared<ViewHub>(o);
  EXPECT_FALSE(ViewServer::Start(o, "", hub, FindWebDir(""), &why));  // ...but no token was resolved
  EXPECT_NE(why.find("token"), std::string::npos) << why;
}

TEST(ViewServer, ManyPagesGetOneDeltaPerMapUpdate) {
  Served s(Loopback(), "");
  ASSERT_TRUE(s.server);
  const int a = OpenStream(s.server->port()), b = OpenStream(s.server->port());
  ASSERT_TRUE(test::WaitFor([&] { return s.hub->counters().clients == 2; }, 30));
  MapSnapshot m;
  for (int i = 0; i < 100; ++i) m.points.emplace_back(0.1f * i, 0.f, 0.05f * i);
  SnapshotSubmap sm;
  sm.key = "front#1";
  m.submaps.push_back(sm);
  s.hub->SetMap(m, SnapshotGrid());
  m.points.emplace_back(3.f, 0.f, 2.f);
  s.hub->SetMap(m, SnapshotGrid());
  EXPECT_EQ(s.hub->counters().map_updates, 2);  // two updates, whatever the number of pages
  for (int fd : {a, b}) {
    std::string seen;
    EXPECT_TRUE(ReadUntil(fd, "\"base\":1", 30, &seen)) << seen;  // the second is a delta from the first
    EXPECT_NE(seen.find("event: map"), std::string::npos);
    ::close(fd);
  }
  // A page that opens now gets the whole view, numbered as the last delta.
  const auto whole = nlohmann::json::parse(s.Client().Get("/api/map")->body);
  EXPECT_EQ(whole["seq"], 2);
  EXPECT_EQ(whole["counts"]["points"], 101);
}

TEST(ViewServer, AStalledBrowserLosesItsOldestMessagesAndHoldsUpNoOne) {
  Served s(Loopback(), "");
  ASSERT_TRUE(s.server);
  const int stalled = OpenStream(s.server->port(), true);  // never reads
  const int reader = OpenStream(s.server->port());
  ASSERT_TRUE(ReadUntil(reader, "200 OK", 30));
  ASSERT_TRUE(test::WaitFor([&] { return s.hub->counters().clients == 2; }, 30));
  // 20 MB of status for each stream: the stalled one cannot take it.
  const auto t0 = std::chrono::steady_clock::now();
  const nlohmann::json big = {{"filler", std::string(10000, 'x')}};
  for (int i = 0; i < 2000; ++i) s.hub->SetStatus(big);
  s.hub->SetStatus({{"summary", "the last one"}});
  const double pushed_s = test::SecondsSince(t0);
  EXPECT_LT(pushed_s, 30.0);  // bounded queues: never waits on a browser (generous under load)
  std::string seen;
  EXPECT_TRUE(ReadUntil(reader, "the last one", 60, &seen)) << "the reading browser got the newest status: "
                                                            << seen.size() << " bytes: " << seen.substr(0, 300);
  EXPECT_GT(s.hub->counters().dropped, 0) << "the stalled stream dropped its oldest";
  // A fourth stream over view.max_clients (3) is refused with a reason.
  const int third = OpenStream(s.server->port());
  ASSERT_TRUE(test::WaitFor([&] { return s.hub->counters().clients == 3; }, 30));
  const int fourth = OpenStream(s.server->port());
  EXPECT_TRUE(ReadUntil(fourth, "max_clients", 30, &seen)) << seen;
  EXPECT_NE(seen.find("503"), std::string::npos);
  for (int fd : {stalled, reader, third, fourth}) ::close(fd);
}

}  // namespace
}  // namespace rumi
