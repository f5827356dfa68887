/* The shared byte count of engine.h's memory_account. */
#include "engine.h"

void memory_account_init(memory_account *account, size_t limit)
{
    atomic_init(&account->used, 0);
    account->limit = limit;
}

int memory_account_take(memory_account *account, size_t bytes)
{
    size_t used = atomic_load_explicit(&account->used, memory_order_relaxed);
    do {
        if (used > account->limit || bytes > account->limit - used)
            return -1;
    } while (!atomic_compare_exchange_weak_explicit(&account->used, &used, used + bytes, memory_order_relaxed,
                                                    memory_order_relaxed));
    return 0;
}

void memory_account_charge(memory_account *account, size_t bytes)
{
    atomic_fetch_add_explicit(&account->used, bytes, memory_order_relaxed);
}

void memory_account_give(memory_account *account, size_t bytes)
{
    atomic_fetch_sub_explicit(&account->used, bytes, memory_order_relaxed);
}

size_t memory_account_used(const memory_account *account)
{
    return atomic_load_explicit(&((memory_account *)account)->used, memory_order_relaxed);
}

size_t memory_account_left(const memory_account *account)
{
    size_t used = memory_account_used(account);
    return used >= account->limit ? 0 : account->limit - used;
}
