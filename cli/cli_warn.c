#include "cli_warn.h"

#include <stdio.h>

void cli_warn_print(const char *command, const warnings_t *w)
{
    for (size_t i = 0; i < warnings_count(w); i++)
        fprintf(stderr, "prismfarm %s: warning: %s\n", command, warnings_at(w, i));
    if (warnings_dropped(w) > 0)
        fprintf(stderr, "prismfarm %s: warning: %zu more warnings not shown\n", command,
                warnings_dropped(w));
}
