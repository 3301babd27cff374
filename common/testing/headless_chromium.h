#pragma once
// For tests only: the web view's page in a real browser. Headless Chromium
// (Debian's `chromium`, installed by scripts/setup.sh) loads it, runs its
// script, and dumps the DOM it left, which the test reads by element id.
#include <filesystem>
#include <string>

#include "common/testing/process.h"

namespace rumi::test {

// "chromium" (or chromium-browser, google-chrome) when one is on the PATH, else "".
std::string FindChromium();

// The command line of a headless run as root (--no-sandbox) with its own
// profile folder, its log on stderr, and a virtual time budget (a page's
// timers run that long in virtual time; an open request holds it still).
// Append the action (--dump-dom, --screenshot=...) and the address.
std::string HeadlessChromium(const std::string& chromium, const std::filesystem::path& profile,
                             int virtual_time_ms = 5000);

// The DOM of `url` once its script ran (bounded by timeout_s), Chromium's
// log appended to `log`.
CommandResult DumpDom(const std::string& headless, const std::string& url, const std::filesystem::path& log,
                      int timeout_s = 180);

// The text of the element with this id in a dumped DOM ("<no #id>" when absent).
std::string ElementText(const std::string& dom, const std::string& id);

}  // namespace rumi::test
