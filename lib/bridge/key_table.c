/* The admission state machine's tables (admission.h): open addressing with linear probing,
 * keyed by a 64-bit pair, deleting by backward shift (no tombstones). */
#include <stdlib.h>
#include <string.h>

#include "admission.h"

int key_table_init(table_t *table, uint32_t capacity)
{
    size_t size = 16;
    while (size < 2 * (size_t)capacity) {
        size *= 2;
    }
    table->slots = calloc(size, sizeof *table->slots);
    table->mask = size - 1;
    return table->slots != NULL;
}

void key_table_clear(table_t *table)
{
    memset(table->slots, 0, (table->mask + 1) * sizeof *table->slots);
}

static uint64_t mix(uint64_t a, uint64_t b)
{
    uint64_t h = a * 0x9E3779B97F4A7C15ull ^ (b + 0xBF58476D1CE4E5B9ull + (a << 6) + (a >> 2));
    h ^= h >> 31;
    h *= 0x94D049BB133111EBull;
    return h ^ (h >> 29);
}

/* The slot holding the key, or the empty slot where it would go. Never full: capacity is
 * reserved before insertion and the table has twice the slots. */
slot_t *key_table_find(const table_t *table, uint64_t a, uint64_t b)
{
    size_t index = (size_t)mix(a, b) & table->mask;
    for (;;) {
        slot_t *slot = &table->slots[index];
        if (!slot->used || (slot->key_a == a && slot->key_b == b)) {
            return slot;
        }
        index = (index + 1) & table->mask;
    }
}

/* Removes a used slot, moving later keys of its probe run back so every key stays reachable
 * from its home slot (linear probing's deletion, no tombstones). */
void key_table_remove(table_t *table, slot_t *slot)
{
    size_t hole = (size_t)(slot - table->slots);
    size_t next = hole;
    for (;;) {
        next = (next + 1) & table->mask;
        slot_t *candidate = &table->slots[next];
        if (!candidate->used) {
            break;
        }
        size_t home = (size_t)mix(candidate->key_a, candidate->key_b) & table->mask;
        /* it stays when its home lies cyclically in (hole, next] */
        int stays = hole <= next ? (hole < home && home <= next) : (hole < home || home <= next);
        if (!stays) {
            table->slots[hole] = *candidate;
            hole = next;
        }
    }
    table->slots[hole].used = 0;
}

void key_table_take(slot_t *slot, uint64_t a, uint64_t b, uint64_t content)
{
    slot->used = 1;
    slot->key_a = a;
    slot->key_b = b;
    slot->content = content;
}
