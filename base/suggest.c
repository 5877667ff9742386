#include "suggest.h"

#include <string.h>

static char lower(char c)
{
    return c >= 'A' && c <= 'Z' ? (char)(c - 'A' + 'a') : c;
}

static int min3(int a, int b, int c)
{
    int m = a < b ? a : b;
    return m < c ? m : c;
}

/* Three rows of the dynamic programme suffice: the swap of two neighbours looks two back. */
int suggest_distance(const char *a, const char *b)
{
    size_t la = strlen(a), lb = strlen(b);
    if (la > SUGGEST_MAX_LEN || lb > SUGGEST_MAX_LEN)
        return -1;
    int rows[3][SUGGEST_MAX_LEN + 1];
    int *prev2 = rows[0], *prev = rows[1], *cur = rows[2];
    for (size_t j = 0; j <= lb; j++)
        prev[j] = (int)j;
    for (size_t i = 1; i <= la; i++) {
        cur[0] = (int)i;
        for (size_t j = 1; j <= lb; j++) {
            int cost = lower(a[i - 1]) != lower(b[j - 1]);
            cur[j] = min3(prev[j] + 1, cur[j - 1] + 1, prev[j - 1] + cost);
            if (i > 1 && j > 1 && lower(a[i - 1]) == lower(b[j - 2]) &&
                lower(a[i - 2]) == lower(b[j - 1]) && prev2[j - 2] + 1 < cur[j])
                cur[j] = prev2[j - 2] + 1;
        }
        int *t = prev2;
        prev2 = prev;
        prev = cur;
        cur = t;
    }
    return prev[lb];
}

/* How many edits still read as a slip of the hand rather than another word. */
static int bound(const char *word)
{
    size_t n = strlen(word);
    return n <= 4 ? 1 : n <= 8 ? 2 : 3;
}

suggest_t suggest_begin(const char *word)
{
    return (suggest_t){.word = word, .best = NULL, .dist = 0};
}

void suggest_consider(suggest_t *s, const char *candidate)
{
    if (!s->word || !candidate)
        return;
    int d = suggest_distance(s->word, candidate);
    if (d < 0 || d > bound(s->word))
        return;
    if (!s->best || d < s->dist) {
        s->best = candidate;
        s->dist = d;
    }
}

const char *suggest_result(const suggest_t *s)
{
    if (!s->best || !strcmp(s->best, s->word))
        return NULL;
    return s->best;
}

const char *suggest_nearest(const char *word, const char *const *names, size_t n)
{
    suggest_t s = suggest_begin(word);
    for (size_t i = 0; i < n; i++)
        suggest_consider(&s, names[i]);
    return suggest_result(&s);
}
