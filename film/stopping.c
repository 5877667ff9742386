#include "stopping.h"

const char *stopping_name(stopping_why_t why)
{
    return why == STOPPING_TARGET ? "target" : why == STOPPING_TIME ? "time" : "none";
}

const char *stopping_reason(stopping_why_t why)
{
    return why == STOPPING_TARGET ? "target error reached"
           : why == STOPPING_TIME ? "time limit reached"
                                  : "";
}

bool stopping_active(const stopping_rule_t *rule)
{
    return rule->target_error > 0 || rule->time_limit > 0;
}

stopping_why_t stopping_decide(const stopping_rule_t *rule, const error_estimate_t *e,
                               double elapsed)
{
    if (rule->target_error > 0 && e->valid && e->rel_rmse <= rule->target_error)
        return STOPPING_TARGET;
    if (rule->time_limit > 0 && elapsed >= rule->time_limit)
        return STOPPING_TIME;
    return STOPPING_NONE;
}

pass_record_t stopping_record(int passes, int spp, double elapsed, const error_estimate_t *e)
{
    return (pass_record_t){.pass = passes, .spp = spp, .elapsed = elapsed, .valid = e->valid,
                           .rel_error = e->valid ? e->rel_rmse : 0};
}
