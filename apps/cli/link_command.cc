// `rumi link keygen`: a robot's key for the authenticated link
// (docs/robot_link.md, "Security"): the ground station's key file (0600) and
// the same key as an NVS partition CSV for the robot's flash.
#include <iostream>
#include <memory>

#include "apps/cli/commands.h"
#include "common/atomic_file.h"
#include "ipc/link/link_key.h"

namespace rumi::cli {

namespace {

struct KeygenArgs {
  std::string out, nvs_csv;
  bool force = false;
};

void Keygen(const KeygenArgs& a) {
  LinkKey key;
  std::string why;
  const std::string csv = a.nvs_csv.empty() ? a.out + ".nvs.csv" : a.nvs_csv;
  if (!GenerateLinkKey(&key, &why) || !WriteLinkKey(a.out, key, a.force, &why)) {
    std::cerr << "rumi link keygen: " << why << "\n";
    throw CLI::RuntimeError(1);
  }
  if (!WriteFileAtomically(csv, LinkKeyNvsCsv(key), &why, 0600)) {
    std::cerr << "rumi link keygen: " << why << "\n";
    throw CLI::RuntimeError(1);
  }
  std::cout << "rumi link keygen: key written to " << a.out << " (0600): set source.link.key_file: " << a.out
            << "\n"
            << "the robot's copy: " << csv << " (0600); flash it into the robot's NVS (firmware/README.md):\n"
            << "  $IDF_PATH/components/nvs_flash/nvs_partition_generator/nvs_partition_gen.py generate " << csv
            << " rumi_nvs.bin 0x6000\n"
            << "  esptool.py write_flash 0x9000 rumi_nvs.bin\n"
            << "then delete " << csv << ".\n";
}

}  // namespace

void RegisterLinkCommand(CLI::App* app) {
  CLI::App* link = app->add_subcommand("link", "the robot link's keys");
  link->require_subcommand(1);
  auto a = std::make_shared<KeygenArgs>();
  CLI::App* keygen = link->add_subcommand("keygen", "a new robot key: the ground station's file and the robot's NVS CSV");
  keygen->add_option("--out", a->out, "the ground station's key file (source.link.key_file), written 0600")
      ->required();
  keygen->add_option("--nvs-csv", a->nvs_csv, "the robot's copy as an NVS partition CSV (default: OUT.nvs.csv)");
  keygen->add_flag("--force", a->force, "replace an existing key file (the robot must get the new key)");
  keygen->callback([a] { Keygen(*a); });
}

}  // namespace rumi::cli
