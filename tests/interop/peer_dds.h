/* The interop peer's Cyclone DDS helpers (peer_dds.c): entities with storey's QoS, match
 * counts and the report of an endpoint that did not match. */
#ifndef STOREY_INTEROP_PEER_DDS_H
#define STOREY_INTEROP_PEER_DDS_H

#include <stdbool.h>
#include <stdint.h>

#include "dds/dds.h"

/* Prints "peer: what: rc" and exits 2 (a DDS call failed). */
void die(const char* what, dds_return_t rc);

dds_entity_t make_writer(dds_entity_t participant, const dds_topic_descriptor_t* desc,
                         const char* name, bool reliable, bool transient_local, int depth);

/* storey's kLatest outputs: reliable, transient local, keep last 1. */
dds_entity_t make_latest_reader(dds_entity_t participant, const dds_topic_descriptor_t* desc,
                                const char* name);

uint32_t publication_matches(dds_entity_t writer);

/* Prints the endpoint's match count and incompatible QoS count to stderr. */
void report_endpoint(const char* name, dds_entity_t entity, bool writer);

#endif
