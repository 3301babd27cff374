/* A DDS client of rumi in plain C (docs/dds.md): prints the status of one
 * rumi instance, then asks for its global trajectory and prints its length.
 * Only Cyclone DDS and the C types idlc makes from rumi_map.idl:
 *
 *   idlc rumi_map.idl
 *   cc -o rumi_status example_client.c rumi_map.c -lddsc
 *   ./rumi_status default lo        # instance, network interface
 *
 * Exit 0 when both answers came, 1 when the server did not answer in time. */
#include <dds/dds.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "rumi_map.h"

static dds_entity_t open_topic(dds_entity_t pp, const dds_topic_descriptor_t* desc, const char* instance,
                               const char* name) {
  char topic[256];
  snprintf(topic, sizeof topic, "rumi/%s/%s", instance, name);
  return dds_create_topic(pp, desc, topic, NULL, NULL);
}

int main(int argc, char** argv) {
  const char* instance = argc > 1 ? argv[1] : "default";
  const char* interface = argc > 2 ? argv[2] : "lo";
  /* The same transport as the server: one interface, no shared memory. */
  char config[512];
  snprintf(config, sizeof config,
           "<CycloneDDS><Domain Id=\"any\"><General><Interfaces><NetworkInterface name=\"%s\"/></Interfaces>"
           "</General><SharedMemory><Enable>false</Enable></SharedMemory></Domain></CycloneDDS>",
           interface);
  dds_set_log_mask(DDS_LC_FATAL | DDS_LC_ERROR);
  if (dds_create_domain(0, config) < 0) return 1;
  const dds_entity_t pp = dds_create_participant(0, NULL, NULL);
  if (pp < 0) return 1;

  /* Status: reliable, transient-local, last value: it comes on joining. */
  dds_qos_t* state = dds_create_qos();
  dds_qset_reliability(state, DDS_RELIABILITY_RELIABLE, DDS_SECS(1));
  dds_qset_durability(state, DDS_DURABILITY_TRANSIENT_LOCAL);
  dds_qset_history(state, DDS_HISTORY_KEEP_LAST, 1);
  const dds_entity_t status_reader =
      dds_create_reader(pp, open_topic(pp, &rumi_dds_Status_desc, instance, "status"), state, NULL);
  /* Requests and replies: reliable, keep all. */
  dds_qos_t* rpc = dds_create_qos();
  dds_qset_reliability(rpc, DDS_RELIABILITY_RELIABLE, DDS_SECS(1));
  dds_qset_history(rpc, DDS_HISTORY_KEEP_ALL, 0);
  const dds_entity_t request_writer =
      dds_create_writer(pp, open_topic(pp, &rumi_dds_Request_desc, instance, "request"), rpc, NULL);
  const dds_entity_t reply_reader =
      dds_create_reader(pp, open_topic(pp, &rumi_dds_Reply_desc, instance, "reply"), rpc, NULL);
  dds_delete_qos(state);
  dds_delete_qos(rpc);

  int ok = 0;
  for (int i = 0; i < 1000 && !ok; ++i) { /* up to 10 s */
    void* samples[1] = {NULL};
    dds_sample_info_t info[1];
    if (dds_take(status_reader, samples, info, 1, 1) > 0) {
      const rumi_dds_Status* s = samples[0];
      if (info[0].valid_data) {
        printf("instance %s: %s, %d keyframes, %lld points, last save %s\n", s->instance, s->state, (int)s->keyframes,
               (long long)s->points, s->last_save);
        ok = 1;
      }
      dds_return_loan(status_reader, samples, 1);
    } else {
      dds_sleepfor(DDS_MSECS(10));
    }
  }
  if (!ok) {
    fprintf(stderr, "no status from rumi instance %s\n", instance);
    return 1;
  }

  /* The trajectory: one request, a reply in chunks 0..chunks-1. The request
   * goes again while nothing comes back (the server may not know our
   * reader yet). */
  rumi_dds_Request request;
  memset(&request, 0, sizeof request);
  request.client_id = ((uint64_t)getpid() << 32) ^ (uint64_t)time(NULL);
  request.request_id = 1;
  request.version = 2;
  request.kind = rumi_dds_KIND_TRAJECTORY;
  request.submap = "";
  long long poses = 0;
  uint32_t got = 0, chunks = 1;
  for (int i = 0; i < 1000 && got < chunks; ++i) {
    if (got == 0 && i % 100 == 0) dds_write(request_writer, &request);
    void* samples[1] = {NULL};
    dds_sample_info_t info[1];
    if (dds_take(reply_reader, samples, info, 1, 1) > 0) {
      const rumi_dds_Reply* r = samples[0];
      if (info[0].valid_data && r->client_id == request.client_id && r->request_id == request.request_id &&
          r->chunk == got) {
        if (r->code != rumi_dds_CODE_OK) {
          fprintf(stderr, "refused: %s\n", r->error);
          dds_return_loan(reply_reader, samples, 1);
          return 1;
        }
        chunks = r->chunks;
        poses += r->poses._length;
        ++got;
      }
      dds_return_loan(reply_reader, samples, 1);
    } else {
      dds_sleepfor(DDS_MSECS(10));
    }
  }
  if (got < chunks) {
    fprintf(stderr, "no trajectory from rumi instance %s\n", instance);
    return 1;
  }
  printf("trajectory: %lld poses in %u chunk(s)\n", poses, chunks);
  dds_delete(pp);
  return 0;
}
