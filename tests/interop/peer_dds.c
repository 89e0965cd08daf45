/* The interop peer's Cyclone DDS helpers: see peer_dds.h. */
#include "peer_dds.h"

#include <stdio.h>
#include <stdlib.h>

void die(const char* what, dds_return_t rc) {
  fprintf(stderr, "peer: %s: %s\n", what, dds_strretcode(rc));
  exit(2);
}

static dds_entity_t make_topic(dds_entity_t participant, const dds_topic_descriptor_t* desc,
                               const char* name) {
  dds_entity_t topic = dds_create_topic(participant, desc, name, NULL, NULL);
  if (topic < 0) die(name, topic);
  return topic;
}

static dds_qos_t* make_qos(bool reliable, bool transient_local, int depth) {
  dds_qos_t* qos = dds_create_qos();
  dds_qset_reliability(qos, reliable ? DDS_RELIABILITY_RELIABLE : DDS_RELIABILITY_BEST_EFFORT,
                       DDS_SECS(1));
  dds_qset_durability(qos,
                      transient_local ? DDS_DURABILITY_TRANSIENT_LOCAL : DDS_DURABILITY_VOLATILE);
  dds_qset_history(qos, DDS_HISTORY_KEEP_LAST, depth);
  return qos;
}

dds_entity_t make_writer(dds_entity_t participant, const dds_topic_descriptor_t* desc,
                         const char* name, bool reliable, bool transient_local, int depth) {
  dds_qos_t* qos = make_qos(reliable, transient_local, depth);
  dds_entity_t writer =
      dds_create_writer(participant, make_topic(participant, desc, name), qos, NULL);
  dds_delete_qos(qos);
  if (writer < 0) die(name, writer);
  return writer;
}

/* storey's kLatest outputs: reliable, transient local, keep last 1. */
dds_entity_t make_latest_reader(dds_entity_t participant, const dds_topic_descriptor_t* desc,
                                const char* name) {
  dds_qos_t* qos = make_qos(true, true, 1);
  dds_entity_t reader =
      dds_create_reader(participant, make_topic(participant, desc, name), qos, NULL);
  dds_delete_qos(qos);
  if (reader < 0) die(name, reader);
  return reader;
}

uint32_t publication_matches(dds_entity_t writer) {
  dds_publication_matched_status_t st;
  if (dds_get_publication_matched_status(writer, &st) < 0) return 0;
  return st.current_count;
}

static uint32_t subscription_matches(dds_entity_t reader) {
  dds_subscription_matched_status_t st;
  if (dds_get_subscription_matched_status(reader, &st) < 0) return 0;
  return st.current_count;
}

void report_endpoint(const char* name, dds_entity_t entity, bool writer) {
  if (writer) {
    dds_offered_incompatible_qos_status_t q;
    dds_get_offered_incompatible_qos_status(entity, &q);
    fprintf(stderr, "peer:   writer %-28s matched %u reader(s), %u incompatible QoS\n", name,
            publication_matches(entity), q.total_count);
  } else {
    dds_requested_incompatible_qos_status_t q;
    dds_get_requested_incompatible_qos_status(entity, &q);
    fprintf(stderr, "peer:   reader %-28s matched %u writer(s), %u incompatible QoS\n", name,
            subscription_matches(entity), q.total_count);
  }
}
