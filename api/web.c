/* web.c - the portal: GET / (index.html) and GET /web/{file} (its script,
 * style sheet and the vendored three.js), served from the copies of web/
 * compiled into the binary (web/embed.sh -> BUILD/gen/web_files.c), so a
 * running service needs no source tree.  Every page response carries a
 * strict Content-Security-Policy: scripts, styles and connections from
 * this origin only, no inline code, layer previews as blob: images.
 * The page itself is docs/portal.md.
 */
#include "api/api_internal.h"

#include <string.h>

static const char csp[] =
	"default-src 'self'; script-src 'self'; style-src 'self'; img-src 'self' blob: data:; "
	"connect-src 'self'; object-src 'none'; base-uri 'none'; form-action 'self'; "
	"frame-ancestors 'none'";

static const char *content_type(const char *name)
{
	const char *dot = strrchr(name, '.');

	if (!dot)
		return "application/octet-stream";
	if (!strcmp(dot, ".html"))
		return "text/html; charset=utf-8";
	if (!strcmp(dot, ".js"))
		return "text/javascript; charset=utf-8";
	if (!strcmp(dot, ".css"))
		return "text/css; charset=utf-8";
	if (!strcmp(dot, ".svg"))
		return "image/svg+xml";
	return "application/octet-stream";
}

static enum MHD_Result serve_file(struct api_req *r, const char *name)
{
	for (size_t i = 0; i < api_web_file_count; i++) {
		const struct api_web_file *f = &api_web_files[i];
		struct MHD_Response *resp;
		if (strcmp(f->name, name) != 0)
			continue;
		resp = MHD_create_response_from_buffer(f->len, (void *)(uintptr_t)f->data,
						       MHD_RESPMEM_PERSISTENT);
		if (!resp)
			return MHD_NO;
		MHD_add_response_header(resp, MHD_HTTP_HEADER_CONTENT_TYPE, content_type(name));
		MHD_add_response_header(resp, "Content-Security-Policy", csp);
		MHD_add_response_header(resp, "X-Content-Type-Options", "nosniff");
		MHD_add_response_header(resp, "Referrer-Policy", "no-referrer");
		MHD_add_response_header(resp, "X-Frame-Options", "DENY");
		return api_queue(r, MHD_HTTP_OK, resp);
	}
	return api_problem(r, PROB_NOT_FOUND, NULL, "no portal file '%s'", name);
}

enum MHD_Result api_web_index(struct api_req *r)
{
	return serve_file(r, "index.html");
}

enum MHD_Result api_web_asset(struct api_req *r)
{
	if (!strcmp(r->arg[0], "index.html"))
		return api_problem(r, PROB_NOT_FOUND, NULL, "the portal is at /");
	return serve_file(r, r->arg[0]);
}
