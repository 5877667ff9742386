/* cli_warn: a scene's warnings (scenefile/warnings.h) as the commands print them: one line each
 * on stderr, "prismfarm CMD: warning: file:line:col: text", and how many more were dropped. */
#ifndef PRISMFARM_CLI_WARN_H
#define PRISMFARM_CLI_WARN_H

#include "warnings.h"

void cli_warn_print(const char *command, const warnings_t *w);

#endif
