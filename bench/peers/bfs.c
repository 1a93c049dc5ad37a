/* bfs.c: a plain single-core breadth-first explorer of a place/transition net, the peer that
 * bench/bench_scale.py measures our explorer against (issue 27). Not part of the toolkit.
 *
 * Input (the text dump bench/peers/netdump.py writes, whitespace-separated integers):
 *
 *     places P  transitions T
 *     initial m_0 ... m_{P-1}
 *     then per transition: n_in (place weight) x n_in  n_out (place weight) x n_out
 *
 * The search: a marking is P bytes (one token count per place, at most 255) padded to whole
 * 64-bit words; markings are appended to one array in the order they are found, which is also
 * the BFS queue (marking i is expanded after every marking before it). Seen markings are an
 * open-addressing hash set (linear probing, load at most 1/2) of 32-bit indices into that
 * array. For each marking every transition is tried in turn. The arcs are counted, not kept.
 *
 * Output, one line: markings N arcs E deadlocks D max_tokens K
 * Exit 2 on bad input, 3 when a place would exceed 255 tokens or memory runs out.
 *
 *     cc -O2 -o bfs bfs.c && ./bfs net.txt
 */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct {
    int n_in, n_out;
    int *in_place, *in_w, *out_place, *out_w;
} transition;

static size_t words;              /* 64-bit words per marking */
static uint64_t *markings;        /* markings[i * words ...] */
static size_t n_markings, cap_markings;
static uint32_t *table;           /* index + 1, 0 = empty */
static size_t table_size;         /* a power of two */

static void fail(int status, const char *what) {
    fprintf(stderr, "bfs: %s\n", what);
    exit(status);
}

static uint64_t hash(const uint64_t *m) {
    uint64_t h = words;
    for (size_t k = 0; k < words; k++) {
        h = (h ^ m[k]) * 0x9E3779B97F4A7C15ULL;
        h ^= h >> 29;
    }
    h = (h ^ (h >> 30)) * 0xBF58476D1CE4E5B9ULL;
    h = (h ^ (h >> 27)) * 0x94D049BB133111EBULL;
    return h ^ (h >> 31);
}

static void put(size_t index) {   /* into the table; the marking is known to be absent */
    size_t mask = table_size - 1, slot = hash(markings + index * words) & mask;
    while (table[slot])
        slot = (slot + 1) & mask;
    table[slot] = (uint32_t)(index + 1);
}

static void grow_table(void) {
    free(table);
    table_size *= 2;
    table = calloc(table_size, sizeof *table);
    if (!table)
        fail(3, "out of memory");
    for (size_t i = 0; i < n_markings; i++)
        put(i);
}

/* Whether m is known; if not, it is appended and put in the table. */
static int add(const uint64_t *m) {
    size_t mask = table_size - 1, slot = hash(m) & mask;
    for (uint32_t e; (e = table[slot]) != 0; slot = (slot + 1) & mask)
        if (memcmp(markings + (size_t)(e - 1) * words, m, words * 8) == 0)
            return 1;
    if (n_markings == cap_markings) {
        cap_markings *= 2;
        markings = realloc(markings, cap_markings * words * 8);
        if (!markings)
            fail(3, "out of memory");
    }
    memcpy(markings + n_markings * words, m, words * 8);
    table[slot] = (uint32_t)(n_markings + 1);
    n_markings++;
    if (2 * n_markings > table_size)
        grow_table();
    return 0;
}

static int read_int(FILE *f) {
    int v;
    if (fscanf(f, "%d", &v) != 1 || v < 0)
        fail(2, "bad net dump");
    return v;
}

static void expect(FILE *f, const char *word) {
    char got[32];
    if (fscanf(f, "%31s", got) != 1 || strcmp(got, word) != 0)
        fail(2, "bad net dump");
}

static int *read_arcs(FILE *f, int n, int places, int **weights) {
    int *place = malloc((n + 1) * sizeof *place), *w = malloc((n + 1) * sizeof *w);
    for (int a = 0; a < n; a++) {
        place[a] = read_int(f);
        w[a] = read_int(f);
        if (place[a] >= places)
            fail(2, "bad net dump: no such place");
    }
    *weights = w;
    return place;
}

int main(int argc, char **argv) {
    if (argc != 2)
        fail(2, "usage: bfs NET.txt");
    FILE *f = fopen(argv[1], "r");
    if (!f)
        fail(2, "cannot open the net dump");
    expect(f, "places");
    int places = read_int(f);
    expect(f, "transitions");
    int n_trans = read_int(f);
    words = ((size_t)places + 7) / 8;
    if (!words)
        words = 1;
    transition *ts = calloc((size_t)n_trans + 1, sizeof *ts);
    uint64_t *m0 = calloc(words, 8), *next = calloc(words, 8);
    expect(f, "initial");
    for (int p = 0; p < places; p++) {
        int v = read_int(f);
        if (v > 255)
            fail(3, "more than 255 tokens in a place");
        ((uint8_t *)m0)[p] = (uint8_t)v;
    }
    for (int t = 0; t < n_trans; t++) {
        ts[t].n_in = read_int(f);
        ts[t].in_place = read_arcs(f, ts[t].n_in, places, &ts[t].in_w);
        ts[t].n_out = read_int(f);
        ts[t].out_place = read_arcs(f, ts[t].n_out, places, &ts[t].out_w);
    }
    fclose(f);

    cap_markings = 1024;
    markings = malloc(cap_markings * words * 8);
    table_size = 4096;
    table = calloc(table_size, sizeof *table);
    if (!markings || !table)
        fail(3, "out of memory");
    add(m0);
    uint64_t arcs = 0, deadlocks = 0;
    int max_tokens = 0;
    for (size_t i = 0; i < n_markings; i++) {   /* the array is the BFS queue */
        const uint8_t *m = (const uint8_t *)(markings + i * words);
        for (int p = 0; p < places; p++)
            if (m[p] > max_tokens)
                max_tokens = m[p];
        uint64_t successors = 0;
        for (int t = 0; t < n_trans; t++) {
            const transition *tr = &ts[t];
            int enabled = 1;
            for (int a = 0; a < tr->n_in && enabled; a++)
                enabled = m[tr->in_place[a]] >= tr->in_w[a];
            if (!enabled)
                continue;
            memcpy(next, m, words * 8);
            uint8_t *s = (uint8_t *)next;
            for (int a = 0; a < tr->n_in; a++)
                s[tr->in_place[a]] -= (uint8_t)tr->in_w[a];
            for (int a = 0; a < tr->n_out; a++) {
                int v = s[tr->out_place[a]] + tr->out_w[a];
                if (v > 255)
                    fail(3, "more than 255 tokens in a place");
                s[tr->out_place[a]] = (uint8_t)v;
            }
            add(next);   /* may move the array: m is taken again below */
            m = (const uint8_t *)(markings + i * words);
            successors++;
        }
        arcs += successors;
        deadlocks += successors == 0;
    }
    printf("markings %zu arcs %llu deadlocks %llu max_tokens %d\n", n_markings,
           (unsigned long long)arcs, (unsigned long long)deadlocks, max_tokens);
    return 0;
}
