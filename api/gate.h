/* gate.h - the accept loop and head gate (gate.c): connections are
 * accepted here, held until a whole request head arrives within
 * --head-timeout-s, then handed to MHD; kept-alive connections get the
 * same deadline for their next head.  Used by server.c (start/stop,
 * notifications), http.c (load shedding) and health.c (metrics). */
#ifndef INFILLD_API_GATE_H
#define INFILLD_API_GATE_H

#include <microhttpd.h>

struct api_server;
struct api_gate;
struct err;
struct sockaddr_storage;
/* Bind and listen on ss (s->port gets the bound port); api_gate_run()
 * starts accepting once s->mhd runs. */
int api_gate_start(struct api_server *s, const struct sockaddr_storage *ss, struct err *e);
int api_gate_run(struct api_server *s, struct err *e);
/* Stop accepting and close what the gate holds (before MHD stops);
 * api_gate_free() then frees it (after MHD stopped).  NULL-safe. */
void api_gate_stop(struct api_server *s);
void api_gate_free(struct api_server *s);
/* MHD_OPTION_NOTIFY_CONNECTION callback (cls = the server). */
void api_gate_notify(void *cls, struct MHD_Connection *conn, void **socket_context,
		     enum MHD_ConnectionNotificationCode toe);
/* Connections MHD holds now. */
int api_gate_live(struct api_gate *g);
/* A request on conn has its whole head (the access handler's first
 * call) / has ended (MHD_OPTION_NOTIFY_COMPLETED): between the two
 * calls the connection is not idle; after the second it has
 * --head-timeout-s to send its next whole head. */
void api_gate_request_begins(struct api_server *s, struct MHD_Connection *conn);
void api_gate_request_ends(struct api_server *s, struct MHD_Connection *conn);

#endif
