/* engines.c - GET /v1/engines: the same description `infilld engines`
 * prints (api_engines_json). */
#include "api/api_internal.h"
#include "api/api_json.h"

enum MHD_Result api_engines(struct api_req *r)
{
	return api_json(r, MHD_HTTP_OK, api_engines_json());
}
