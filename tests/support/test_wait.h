/* test_wait: the overall deadline of every wait a test makes for an event -- a log line, a
 * file, a message, a state the master reports. A wait ends at its event, so a passing run never
 * waits this long: the deadline only turns a hang or a missing event into a failure with a
 * message, and it must hold on the slowest machine that runs the tests (a sanitizer build on two
 * cores that other builds keep busy). No test's verdict may depend on how fast the machine is.
 * PRISMFARM_TEST_WAIT_S sets another number of seconds (for a machine slower still, or to make a
 * broken build fail sooner). Header-only. */
#ifndef PRISMFARM_TEST_WAIT_H
#define PRISMFARM_TEST_WAIT_H

#include <stdlib.h>

#define TEST_WAIT_DEFAULT_S 120.0

/* Seconds any one wait for an event may take before the test fails. */
static inline double test_wait_s(void)
{
    const char *v = getenv("PRISMFARM_TEST_WAIT_S");
    double s = v ? strtod(v, NULL) : 0;
    return s > 0 ? s : TEST_WAIT_DEFAULT_S;
}

/* The same in milliseconds, for the APIs that take them. */
static inline int test_wait_ms(void)
{
    return (int)(test_wait_s() * 1000.0);
}

#endif
