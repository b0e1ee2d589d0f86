# Reference values of break-date confidence intervals from R's strucchange
# (Bai 1997, confint.breakpointsfull), of each segment's coefficients and covariance
# (coef, vcov.breakpointsfull) and of its RSS/BIC table (summary.breakpointsfull),
# for tests/reference/test_strucchange_reference.py.
#
#   Rscript tests/reference/strucchange/confint.R > tests/reference/strucchange/confint.json
#
# Needs the Debian packages r-base-core and r-cran-strucchange. The JSON holds the
# data, the break points and the intervals, so that the tests say what changed when
# R or strucchange is upgraded.
suppressMessages(library(strucchange))

intervals <- function(bp, breaks = NULL, level = 0.95, het = TRUE) {
  ci <- suppressWarnings(confint(bp, breaks = breaks, level = level,
                                 het.reg = het, het.err = het))
  unname(ci$confint)
}

case <- function(name, y, X, h, breaks, table_breaks = 0) {
  frame <- data.frame(y = y, X)
  formula <- if (ncol(X) == 0) y ~ 1 else as.formula(paste("y ~", paste(colnames(X), collapse = " + ")))
  bp <- breakpoints(formula, data = frame, h = h)
  table <- if (table_breaks > 0) summary(bp, breaks = table_breaks)$RSS else matrix(nrow = 2, ncol = 0)
  list(
    rss_table = as.numeric(table[1, ]), bic_table = as.numeric(table[2, ]),
    name = name, y = as.numeric(y), X = unname(as.matrix(X)), h = h,
    breakpoints = breakpoints(bp, breaks = breaks)$breakpoints,
    confint_95 = intervals(bp, breaks),
    confint_90 = intervals(bp, breaks, level = 0.90),
    confint_95_homogeneous = intervals(bp, breaks, het = FALSE),
    coef = unname(coef(bp, breaks = breaks)),
    vcov = unname(lapply(vcov(bp, breaks = breaks), unname))
  )
}

data("Nile")
data("UKDriverDeaths")
seat <- log10(UKDriverDeaths)
seat <- cbind(seat, lag(seat, k = -1), lag(seat, k = -12))
colnames(seat) <- c("y", "ylag1", "ylag12")
seat <- window(seat, start = c(1970, 1), end = c(1984, 12))

set.seed(1)
n <- 240
x <- rnorm(n)
two_breaks <- ifelse(seq_len(n) <= 80, 1 + 0.5 * x, ifelse(seq_len(n) <= 170, -0.5 + 1.5 * x, 0.8 - 0.3 * x)) +
  rnorm(n, sd = 0.6)
noise_sd <- ifelse(seq_len(n) <= 120, 0.3, 1.2)  # heteroskedastic segments
hetero <- ifelse(seq_len(n) <= 120, 2 + x, 3 + 0.2 * x) + rnorm(n, sd = noise_sd)

cases <- list(
  case("nile", as.numeric(Nile), matrix(nrow = length(Nile), ncol = 0), 0.15, 1),
  case("seatbelt", as.numeric(seat[, "y"]), data.frame(ylag1 = as.numeric(seat[, "ylag1"]),
       ylag12 = as.numeric(seat[, "ylag12"])), 0.1, 2, table_breaks = 8),
  case("two_breaks", two_breaks, data.frame(x = x), 0.15, 2),
  case("heteroskedastic", hetero, data.frame(x = x), 0.15, 1)
)
to_json <- function(value) {
  if (is.list(value) && !is.null(names(value))) {
    return(paste0("{", paste(sprintf("\"%s\": %s", names(value), sapply(value, to_json)), collapse = ", "), "}"))
  }
  if (is.list(value)) return(paste0("[", paste(sapply(value, to_json), collapse = ", "), "]"))
  if (is.character(value)) return(sprintf("\"%s\"", value))
  if (is.matrix(value)) {
    if (nrow(value) == 0 || ncol(value) == 0) return(sprintf("{\"rows\": %d, \"cols\": %d, \"values\": []}", nrow(value), ncol(value)))
    return(sprintf("{\"rows\": %d, \"cols\": %d, \"values\": [%s]}", nrow(value), ncol(value),
                   paste(ifelse(is.na(t(value)), "null", sprintf("%.17g", t(value))), collapse = ", ")))
  }
  paste0("[", paste(ifelse(is.na(value), "null", sprintf("%.17g", value)), collapse = ", "), "]")
}
cat(to_json(list(strucchange = as.character(packageVersion("strucchange")),
                 R = paste(R.version$major, R.version$minor, sep = "."),
                 cases = cases)), "\n")
