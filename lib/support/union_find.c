/* Union-find over pose indices: the parts of a graph (the core's solvable check, the tools'
 * connected components, the bridge's gauge per part). Compiled into pgem_core (lib/CMakeLists.txt). */
#include "union_find.h"

uint32_t pgem_part_root(uint32_t *parent, uint32_t index)
{
    while (parent[index] != index) {
        parent[index] = parent[parent[index]];
        index = parent[index];
    }
    return index;
}

uint32_t pgem_part_join(uint32_t *parent, uint32_t a, uint32_t b)
{
    const uint32_t root_a = pgem_part_root(parent, a);
    const uint32_t root_b = pgem_part_root(parent, b);
    const uint32_t root = root_a < root_b ? root_a : root_b;
    parent[root_a < root_b ? root_b : root_a] = root;
    return root;
}
