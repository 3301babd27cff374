/* Replays a libFuzzer corpus folder through LLVMFuzzerTestOneInput without
 * libFuzzer (any compiler): ctest's rumi_link_fuzz_replay. */
#include <dirent.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size);

int main(int argc, char** argv) {
  DIR* d;
  struct dirent* e;
  int files = 0;
  if (argc != 2 || !(d = opendir(argv[1]))) {
    fprintf(stderr, "usage: %s CORPUS_DIR (could not open it)\n", argv[0]);
    return 2;
  }
  while ((e = readdir(d))) {
    char path[4096];
    FILE* f;
    static uint8_t buf[1 << 16];
    size_t n;
    if (e->d_name[0] == '.') continue;
    snprintf(path, sizeof(path), "%s/%s", argv[1], e->d_name);
    if (!(f = fopen(path, "rb"))) continue;
    n = fread(buf, 1, sizeof(buf), f);
    fclose(f);
    LLVMFuzzerTestOneInput(buf, n);
    ++files;
  }
  closedir(d);
  printf("replayed %d inputs\n", files);
  return files > 0 ? 0 : 1;
}
