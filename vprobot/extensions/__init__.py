"""Extension points: named registries (`registry`) and plugins from outside the
package (`plugins`).
"""
