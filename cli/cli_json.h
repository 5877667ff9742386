/* cli_json: the --json output of the prismfarm commands, always built with jansson, which
 * escapes quotes, backslashes and control characters in strings. Text from users, scenes and
 * the master (job and worker names, paths, errors) need not be UTF-8, which JSON strings must
 * be: it gets U+FFFD for each byte that is not part of a UTF-8 character. */
#ifndef PRISMFARM_CLI_JSON_H
#define PRISMFARM_CLI_JSON_H

#include <jansson.h>

/* A JSON string of s (NULL: ""), its bytes that are not UTF-8 replaced by U+FFFD; NULL only
 * when out of memory. */
json_t *cli_json_string(const char *s);

/* Prints v with jansson's flags (JSON_INDENT(2) for a document, 0 for one line) and a newline
 * on stdout, keys in the order set, and releases v. Returns 0, or -1 when v is NULL or the
 * output fails. */
int cli_json_print(json_t *v, size_t flags);

#endif
