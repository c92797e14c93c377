/* "Did you mean ...?": the candidate nearest to a mistyped word, for options, subcommands and
 * configuration keys. */
#ifndef ESR_CORE_SUGGEST_H
#define ESR_CORE_SUGGEST_H

/* Optimal string alignment distance (insertions, deletions, substitutions and swaps of two
 * neighbouring characters each cost 1) between a and b; words longer than 63 characters are
 * compared on their first 63. */
int esr_edit_distance(const char *a, const char *b);
/* The candidate nearest to word when it is close enough to be a typo of it (distance at most
 * 1 for words up to 4 characters, 2 up to 8, 3 beyond; or word a prefix of exactly one
 * candidate), else NULL. Ties go to the first candidate. NULL entries are skipped. */
const char *esr_suggest(const char *word, const char *const *candidates, int n);

#endif
