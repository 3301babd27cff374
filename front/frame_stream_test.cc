#include "front/frame_stream.h"
#include "common/testing/temp_dir.h"
#include "front/testing/front_test_util.h"

#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <thread>

namespace rumi {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

cv::Mat Pattern(int k, int w = 320, int h = 240) {
  cv::Mat img(h, w, CV_8UC3, cv::Scalar(40, 40, 40));
  cv::rectangle(img, cv::Rect(10 + 5 * k, 20, 60, 60), cv::Scalar(250, 250, 250), cv::FILLED);
  cv::putText(img, std::to_string(k), cv::Point(150, 150), cv::FONT_HERSHEY_SIMPLEX, 2, cv::Scalar(200, 90, 30), 3);
  return img;
}


// The ESP32-CAM web server's /stream, on loopback: multipart JPEG frames.
// Each connection gets `per_connection` frames, then the server hangs up (a
// Wi-Fi drop); it accepts up to `connections` clients, one after the other.
class MjpegServer {
 public:
  // hold_s: after its frames, a connection stays open, silent, this long (a
  // stalled camera) before the hang-up.
  MjpegServer(int per_connection, int connections, double fps, int width = 320, double hold_s = 0)
      : per_connection_(per_connection), connections_(connections), fps_(fps), width_(width), hold_s_(hold_s) {
    fd_ = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    a.sin_port = 0;
    const int on = 1;
    ::setsockopt(fd_, SOL_SOCKET, SO_REUSEADDR, &on, sizeof(on));
    if (::bind(fd_, reinterpret_cast<sockaddr*>(&a), sizeof(a)) != 0 || ::listen(fd_, 4) != 0) return;
    socklen_t len = sizeof(a);
    ::getsockname(fd_, reinterpret_cast<sockaddr*>(&a), &len);
    port_ = ntohs(a.sin_port);
    thread_ = std::thread([this] { Serve(); });
  }
  ~MjpegServer() {
    quit_ = true;
    ::shutdown(fd_, SHUT_RDWR);
    ::close(fd_);
    if (thread_.joinable()) thread_.join();
  }
  std::string url() const { return "http://127.0.0.1:" + std::to_string(port_) + "/stream"; }
  int accepted() const { return accepted_; }

 private:
  void Serve() {
    const std::string boundary = "123456789000000000000987654321";
    int k = 0;
    for (int c = 0; c < connections_ && !quit_; ++c) {
      const int client = ::accept4(fd_, nullptr, nullptr, SOCK_CLOEXEC);
      if (client < 0) return;
      ++accepted_;
      char req[4096];
      (void)!::recv(client, req, sizeof(req), 0);  // the GET; its content does not matter
      std::string head = "HTTP/1.1 200 OK\r\nContent-Type: multipart/x-mixed-replace;boundary=" + boundary +
                         "\r\nAccess-Control-Allow-Origin: *\r\n\r\n";
      bool ok = ::send(client, head.data(), head.size(), MSG_NOSIGNAL) > 0;
      for (int i = 0; i < per_connection_ && ok && !quit_; ++i, ++k) {
        std::vector<uint8_t> jpeg;
        cv::Mat img = Pattern(k % 40, width_, width_ * 3 / 4);
        cv::imencode(".jpg", img, jpeg);
        const std::string part = "\r\n--" + boundary + "\r\nContent-Type: image/jpeg\r\nContent-Length: " +
                                 std::to_string(jpeg.size()) + "\r\n\r\n";
        ok = ::send(client, part.data(), part.size(), MSG_NOSIGNAL) > 0 &&
             ::send(client, jpeg.data(), jpeg.size(), MSG_NOSIGNAL) > 0;
        std::this_thread::sleep_for(std::chrono::duration<double>(1.0 / fps_));
      }
      if (ok && c == 0) {
        const auto until = Clock::now() + std::chrono::duration<double>(hold_s_);
        while (!quit_ && Clock::now() < until) std::this_thread::sleep_for(std::chrono::milliseconds(10));
      }
      ::close(client);
    }
  }

  int fd_ = -1, port_ = 0;
  int per_connection_, connections_;
  double fps_;
  int width_;
  double hold_s_;
  std::atomic<bool> quit_{false};
  std::atomic<int> accepted_{0};
  std::thread thread_;
};

// Sets `stop` after `seconds` (or when destroyed): no stream test hangs.
struct StopAfter {
  explicit StopAfter(double seconds)
      : thread([this, seconds] {
          const auto t0 = Clock::now();
          while (!stop && std::chrono::duration<double>(Clock::now() - t0).count() < seconds)
            std::this_thread::sleep_for(std::chrono::milliseconds(20));
          stop = true;
        }) {}
  ~StopAfter() {
    stop = true;
    thread.join();
  }
  std::atomic<bool> stop{false};
  std::thread thread;
};

SourceOptions Capture(const std::string& path) {
  SourceOptions s;
  s.kind = "capture";
  s.path = path;
  s.stall_timeout_s = 1.0;
  s.reconnect_initial_s = 0.1;
  s.reconnect_max_s = 0.4;
  return s;
}

TEST(FrameStream, VideoFilePlaysAtItsRateWithGroundStationTimestamps) {
  const TempDir tmp;
  const fs::path dir = tmp.Create();
  const std::string file = (dir / "walk.avi").string();
  {
    cv::VideoWriter w(file, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 20.0, cv::Size(320, 240));
    ASSERT_TRUE(w.isOpened());
    for (int k = 0; k < 20; ++k) w.write(Pattern(k));
  }
  const PinholeCameraOptions cam = QvgaCamera();
  StreamOpenOptions o;
  o.source = Capture(file);
  o.camera = &cam;
  auto stream = OpenFrameStream(o);
  Frame f;
  std::vector<Timestamp> skipped;
  std::vector<Timestamp> t;
  const auto t0 = Clock::now();
  const auto wall0 = std::chrono::system_clock::now();
  while (stream->Next(&f, &skipped, nullptr)) {
    EXPECT_EQ(f.image.type(), CV_8UC1);
    EXPECT_EQ(f.image.cols, 320);
    t.push_back(f.timestamp);
  }
  const double secs = std::chrono::duration<double>(Clock::now() - t0).count();
  ASSERT_EQ(t.size(), 20u);
  EXPECT_EQ(stream->Status(), "ended");
  for (size_t i = 1; i < t.size(); ++i) EXPECT_GT(t[i], t[i - 1]);
  // Paced at the file's 20 fps: 19 intervals of 50 ms (loose: a shared machine).
  EXPECT_GT(secs, 0.8);
  EXPECT_GT(NsToSeconds(t.back() - t.front()), 0.85);  // never faster than the file; slower on a loaded machine
  EXPECT_LT(NsToSeconds(t.back() - t.front()), 20.0);
  // Capture time on the ground station's wall clock.
  const double wall = std::chrono::duration<double>(wall0.time_since_epoch()).count();
  EXPECT_NEAR(NsToSeconds(t.front()), wall, 5.0);
}

TEST(FrameStream, WrongFrameSizeIsRefusedNamingBothSizes) {
  const TempDir tmp;
  const fs::path dir = tmp.Create();
  const std::string file = (dir / "vga.avi").string();
  {
    cv::VideoWriter w(file, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 20.0, cv::Size(640, 480));
    for (int k = 0; k < 3; ++k) w.write(Pattern(k, 640, 480));
  }
  const PinholeCameraOptions cam = QvgaCamera();
  StreamOpenOptions o;
  o.source = Capture(file);
  o.camera = &cam;
  auto stream = OpenFrameStream(o);
  Frame f;
  try {
    stream->Next(&f, nullptr, nullptr);
    ADD_FAILURE() << "a 640x480 frame passed a 320x240 camera";
  } catch (const StreamError& e) {
    EXPECT_NE(std::string(e.what()).find("640x480 frames but the camera is 320x240"), std::string::npos) << e.what();
  }
  o.source.path = (dir / "missing.avi").string();
  EXPECT_THROW(OpenFrameStream(o), StreamError);
  o.camera = nullptr;
  o.source.path = file;
  EXPECT_THROW(OpenFrameStream(o), StreamError);  // a capture needs its calibration
}

// The ESP32-CAM's HTTP MJPEG stream through OpenCV, with a Wi-Fi drop: the
// stream is reopened and the frames go on, timestamps increasing.
TEST(FrameStream, HttpMjpegStreamReconnectsAfterADrop) {
  MjpegServer server(/*per_connection=*/8, /*connections=*/2, /*fps=*/25);
  const PinholeCameraOptions cam = QvgaCamera();
  StreamOpenOptions o;
  o.source = Capture(server.url());
  o.camera = &cam;
  auto stream = OpenFrameStream(o);
  StopAfter guard(30);  // bounded: the test never hangs on a stream
  std::atomic<bool>& stop = guard.stop;
  std::vector<Timestamp> t;
  bool saw_reconnect = false;
  Frame f;
  while (t.size() < 12 && stream->Next(&f, nullptr, &stop)) {
    t.push_back(f.timestamp);
    saw_reconnect |= server.accepted() > 1;
  }
  ASSERT_GE(t.size(), 12u) << "status: " << stream->Status();
  EXPECT_TRUE(saw_reconnect);
  EXPECT_EQ(server.accepted(), 2);
  for (size_t i = 1; i < t.size(); ++i) EXPECT_GT(t[i], t[i - 1]);
}

// A camera that stops sending without hanging up: after stall_timeout_s
// without a frame the stream is reopened (and the frames come again).
TEST(FrameStream, AStalledStreamIsReopened) {
  // Clients that gave up while the stall lasts are accepted (and dropped) too.
  MjpegServer server(/*per_connection=*/5, /*connections=*/20, /*fps=*/25, 320, /*hold_s=*/2.5);
  const PinholeCameraOptions cam = QvgaCamera();
  StreamOpenOptions o;
  o.source = Capture(server.url());
  o.camera = &cam;
  auto stream = OpenFrameStream(o);
  StopAfter guard(30);
  std::atomic<bool>& stop = guard.stop;
  std::vector<Timestamp> t;
  Frame f;
  while (t.size() < 8 && stream->Next(&f, nullptr, &stop)) t.push_back(f.timestamp);
  ASSERT_GE(t.size(), 8u) << "status: " << stream->Status();
  EXPECT_GE(server.accepted(), 2);
  // The gap is the stall: at least the read timeout, within the server's hold + a reconnect.
  const double gap = NsToSeconds(t[5] - t[4]);
  EXPECT_GT(gap, 0.9);
  EXPECT_LT(gap, 10.0);
}

TEST(FrameStream, AStreamThatIsNotThereYetIsRetriedUntilStopped) {
  const PinholeCameraOptions cam = QvgaCamera();
  StreamOpenOptions o;
  int port = 0;
  {  // a port nobody listens on: bound, then let go
    const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t len = sizeof(a);
    ASSERT_EQ(::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof(a)), 0);
    ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len);
    port = ntohs(a.sin_port);
    ::close(fd);
  }
  o.source = Capture("http://127.0.0.1:" + std::to_string(port) + "/stream");
  o.camera = &cam;
  auto stream = OpenFrameStream(o);
  std::atomic<bool> stop{false};
  std::thread t([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(1500));
    stop = true;
  });
  Frame f;
  const auto t0 = Clock::now();
  EXPECT_FALSE(stream->Next(&f, nullptr, &stop));
  t.join();
  EXPECT_LT(std::chrono::duration<double>(Clock::now() - t0).count(), 10.0);
  EXPECT_NE(stream->Status().find("reconnecting"), std::string::npos) << stream->Status();
}

TEST(FrameStream, AWaitingLinkStreamCallsItsIdleUpkeep) {
  // No robot sends: Next waits, and calls the caller's upkeep about every
  // 200 ms (how a halted robot is resumed when it sends nothing).
  const PinholeCameraOptions cam = QvgaCamera();
  StreamOpenOptions o;
  o.source.kind = "link";
  o.source.link.bind = "127.0.0.1:0";
  o.source.link.insecure = true;  // no robot will come: nothing to authenticate
  o.camera = &cam;
  auto stream = OpenFrameStream(o);
  ASSERT_TRUE(stream->can_halt());
  std::atomic<bool> stop{false};
  std::atomic<int> idle{0};
  stream->SetIdle([&] {
    if (++idle >= 3) stop = true;
  });
  std::thread guard([&] {  // bounded: never more than 20 s
    for (int i = 0; i < 200 && !stop; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(100));
    stop = true;
  });
  Frame f;
  EXPECT_FALSE(stream->Next(&f, nullptr, &stop));
  guard.join();
  EXPECT_GE(idle.load(), 3);
}

}  // namespace
}  // namespace rumi
