#pragma once
// The robot link's per-robot key (docs/robot_link.md, "Security"): 32 random
// bytes, kept as one line of hex in a file only its owner can read (0600) on
// the ground station and in the robot's NVS (namespace "rumi", blob
// "link_key"). `rumi link keygen` makes one.
#include <array>
#include <cstdint>
#include <string>

#include "rumi_link_auth.h"

namespace rumi {

using LinkKey = std::array<uint8_t, RL_KEY_SIZE>;

// Reads a key file: a regular file of at most 4 KiB holding 64 hex digits,
// not readable or writable by group or others (like ssh's private keys).
// False with *why naming the file and what is wrong with it.
bool LoadLinkKey(const std::string& path, LinkKey* key, std::string* why);

// 32 bytes from the kernel's random generator (getrandom(2)).
bool GenerateLinkKey(LinkKey* key, std::string* why);

// Writes the key file (0600, atomically); refuses to replace one unless overwrite.
bool WriteLinkKey(const std::string& path, const LinkKey& key, bool overwrite, std::string* why);

// The key as an ESP-IDF NVS partition CSV (nvs_partition_gen.py; firmware/README.md).
std::string LinkKeyNvsCsv(const LinkKey& key);

// n bytes from getrandom(2); false when the kernel would not give them.
bool RandomBytes(uint8_t* out, size_t n);

}  // namespace rumi
