# Reference values of the partial structural-change model (Bai and Perron 1998):
# y = Θ_j z + Γ x + e with Θ_j changing at the breaks and Γ common to all segments.
# strucchange's breakpoints() has no partial model, so every candidate is fitted
# with lm() on the joint design [z·1{segment 1}, z·1{segment 2}, …, x], for
# tests/estimators/test_segments_partial.py:
#
#   Rscript tests/reference/strucchange/partial.R > tests/reference/strucchange/partial.json
#
# Needs r-base-core only. A break k is the first row (0-based) of the new segment,
# i.e. R rows 1 … k form the first segment; each segment has at least h = ⌊0.15 N⌋ rows.
series <- function(n, breaks, seed) {
  set.seed(seed)
  w <- rnorm(n)                                   # changing regressor (with the intercept)
  x1 <- rnorm(n)                                  # fixed regressor
  quarter <- factor((seq_len(n) - 1) %% 4)
  dummies <- model.matrix(~ quarter)[, -1]        # three quarterly dummies, fixed
  regime <- findInterval(seq_len(n) - 1, breaks) + 1
  level <- c(1, -0.5, 0.8)[regime]
  slope <- c(0.5, 1.5, -0.3)[regime]
  y <- level + slope * w + 0.7 * x1 + dummies %*% c(0.4, -0.6, 0.2) + rnorm(n, sd = 0.5)
  list(y = as.numeric(y), Z = cbind(1, w), X = cbind(x1, unname(dummies)))
}

joint_rss <- function(y, Z, X, breaks) {
  regime <- findInterval(seq_along(y) - 1, breaks)
  design <- do.call(cbind, lapply(seq(0, length(breaks)), function(j) Z * (regime == j)))
  sum(residuals(lm(y ~ 0 + design + X))^2)
}

one <- series(160, 90, 11)
N1 <- length(one$y); h1 <- floor(0.15 * N1)
dates1 <- seq(h1, N1 - h1)
rss1 <- sapply(dates1, function(k) joint_rss(one$y, one$Z, one$X, k))

two <- series(80, c(30, 55), 12)
N2 <- length(two$y); h2 <- floor(0.15 * N2)
best <- Inf; best_pair <- c(NA, NA)
for (a in seq(h2, N2 - 2 * h2)) for (b in seq(a + h2, N2 - h2)) {
  value <- joint_rss(two$y, two$Z, two$X, c(a, b))
  if (value < best) { best <- value; best_pair <- c(a, b) }
}

num <- function(value) paste0("[", paste(sprintf("%.17g", value), collapse = ", "), "]")
mat <- function(value) paste0("[", paste(apply(value, 1, num), collapse = ", "), "]")
case <- function(name, s, h, extra) {
  sprintf("{\"name\": \"%s\", \"y\": %s, \"Z\": %s, \"X\": %s, \"h\": %d, %s}",
          name, num(s$y), mat(s$Z), mat(s$X), h, extra)
}
cat(sprintf("{\"R\": \"%s.%s\", \"one_break\": %s, \"two_breaks\": %s}\n",
            R.version$major, R.version$minor,
            case("one_break", one, h1,
                 sprintf("\"dates\": %s, \"rss\": %s, \"break\": %d, \"min_rss\": %s",
                         num(dates1), num(rss1), dates1[which.min(rss1)], num(min(rss1)))),
            case("two_breaks", two, h2,
                 sprintf("\"breaks\": %s, \"min_rss\": %s", num(best_pair), num(best)))))
