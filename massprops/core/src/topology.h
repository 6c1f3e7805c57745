/* Edges, shells and duplicate faces (topology.c). */
#ifndef MASSPROPS_TOPOLOGY_H
#define MASSPROPS_TOPOLOGY_H

#include "core.h"

/* Counts over undirected edges (collapsed edges, tail == head, are counted apart). */
typedef struct {
    int64_t edges;             /* distinct undirected edges */
    int64_t boundary;          /* used once */
    int64_t odd;               /* used an odd number of times */
    int64_t unbalanced;        /* used more often in one direction than in the other */
    int64_t nonmanifold;       /* used more than twice */
    int64_t max_uses;
    int64_t collapsed;         /* directed edges from a vertex to itself */
    int64_t degenerate_faces;  /* faces with a repeated vertex */
    int64_t first_boundary[2];   /* (lower, higher) vertex of the first such edge in vertex order, or -1 */
    int64_t first_unbalanced[2];
} EdgeSummary;

/* Every undirected edge, in order of its lower vertex, then its higher one. */
typedef struct {
    int64_t count;
    int64_t *edges;            /* count x 2: lower, higher */
    int32_t *uses;
    int32_t *balance;          /* uses from lower to higher minus uses back */
} EdgeArrays;

/* The vertices no face uses, or an index outside [0, n); -1 when memory ran out. */
int unused_vertices(const void *faces, int faces32, int64_t m, int64_t n, int64_t *unused, int *outside);
int check_indices(const void *faces, int faces32, int64_t m, int64_t n, Failure *failure);
int edge_summary(const void *faces, int faces32, int64_t m, int64_t n, int threads, EdgeSummary *out,
                 EdgeArrays *arrays, Failure *failure);
/* Shells (connected components of faces sharing a vertex): their count, and each face's shell
 * (numbered by first face) in labels, malloc'd, only when there is more than one (else NULL). */
typedef struct {
    int64_t count;
    int64_t *labels;
} ShellResult;
/* edge_summary (without the arrays) and the shells at once: the shells' union-find runs beside the
 * edges' counting; the same counts, shells and labels as edge_summary and face_shells. */
int edge_shells(const void *faces, int faces32, int64_t m, int64_t n, int threads, EdgeSummary *out,
                ShellResult *shells, Failure *failure);
int face_shells(const void *faces, int faces32, int64_t m, int64_t n, int64_t *labels, int64_t *count,
                Failure *failure);
/* Group rows of `columns` indices by their set of indices (labels and first rows in order of first
 * appearance); for triangles (3 columns), count the repeats of the same and the other orientation. */
int row_groups(const void *rows, int rows32, int columns, int64_t m, int64_t *labels, int64_t *first, int64_t *groups,
               int64_t *same, int64_t *opposite, Failure *failure);

#endif
