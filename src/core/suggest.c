#include "core/suggest.h"

#include <string.h>

#define MAXW 64

int esr_edit_distance(const char *a, const char *b)
{
    int la = (int)strnlen(a, MAXW - 1), lb = (int)strnlen(b, MAXW - 1);
    int d[MAXW][MAXW];
    for (int i = 0; i <= la; i++)
        d[i][0] = i;
    for (int j = 0; j <= lb; j++)
        d[0][j] = j;
    for (int i = 1; i <= la; i++)
        for (int j = 1; j <= lb; j++) {
            const int cost = a[i - 1] != b[j - 1];
            int v = d[i - 1][j] + 1;
            if (d[i][j - 1] + 1 < v)
                v = d[i][j - 1] + 1;
            if (d[i - 1][j - 1] + cost < v)
                v = d[i - 1][j - 1] + cost;
            if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1] && d[i - 2][j - 2] + 1 < v)
                v = d[i - 2][j - 2] + 1;
            d[i][j] = v;
        }
    return d[la][lb];
}

const char *esr_suggest(const char *word, const char *const *candidates, int n)
{
    const size_t len = strlen(word);
    const int limit = len <= 4 ? 1 : len <= 8 ? 2 : 3;
    const char *best = NULL, *prefixed = NULL;
    int best_d = limit + 1, n_prefixed = 0;
    for (int i = 0; i < n; i++) {
        if (!candidates[i])
            continue;
        if (len > 0 && !strncmp(candidates[i], word, len) && (!prefixed || strcmp(prefixed, candidates[i]))) {
            prefixed = candidates[i];
            n_prefixed++;
        }
        const int d = esr_edit_distance(word, candidates[i]);
        if (d < best_d) {
            best_d = d;
            best = candidates[i];
        }
    }
    if (best)
        return best;
    return n_prefixed == 1 ? prefixed : NULL;
}
