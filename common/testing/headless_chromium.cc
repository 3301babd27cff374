#include "common/testing/headless_chromium.h"

#include <regex>

namespace rumi::test {

std::string FindChromium() {
  for (const char* c : {"chromium", "chromium-browser", "google-chrome"})
    if (RunCommand(std::string("command -v ") + c + " >/dev/null").code == 0) return c;
  return "";
}

std::string HeadlessChromium(const std::string& chromium, const std::filesystem::path& profile, int virtual_time_ms) {
  return chromium + " --headless --no-sandbox --disable-gpu --no-first-run --mute-audio --disable-dev-shm-usage " +
         "--user-data-dir=" + profile.string() + " --enable-logging=stderr --v=0 --virtual-time-budget=" +
         std::to_string(virtual_time_ms) + " ";
}

CommandResult DumpDom(const std::string& headless, const std::string& url, const std::filesystem::path& log,
                      int timeout_s) {
  return RunCommand("timeout " + std::to_string(timeout_s) + " " + headless + "--dump-dom '" + url + "' 2>>" +
                    log.string());
}

std::string ElementText(const std::string& dom, const std::string& id) {
  const std::regex re("id=\"" + id + "\"[^>]*>([^<]*)<");
  std::smatch m;
  return std::regex_search(dom, m, re) ? m[1].str() : "<no #" + id + ">";
}

}  // namespace rumi::test
