# Writes Hansen's (1997) response-surface coefficients for the p-values of the
# supF, aveF and expF structural-change tests, as R's strucchange stores them
# (strucchange:::sc.beta.sup, sc.beta.ave, sc.beta.exp), into the package data
# that ltvmodels.core.breaktests reads:
#
#   Rscript tests/reference/strucchange/hansen_tables.R src/ltvmodels/core/tables
#
# Source: B. E. Hansen (1997), "Approximate asymptotic p values for
# structural-change tests", Journal of Business & Economic Statistics 15(1), 60-67.
# Each table has 25 rows per number of regressors k = 1 ... 40 (row r for the
# trimming tau = 0.49, 0.47, ..., 0.01: tau = (51 - 2 r) / 100), the polynomial
# coefficients of the statistic (2 for supF, 4 for aveF and expF) and the
# degrees of freedom of the chi-square the polynomial is referred to.
suppressMessages(library(strucchange))
args <- commandArgs(trailingOnly = TRUE)
out <- if (length(args) > 0) args[1] else "."
for (type in c("sup", "ave", "exp")) {
  beta <- get(paste0("sc.beta.", type), asNamespace("strucchange"))
  path <- file.path(out, sprintf("hansen_1997_%s.txt", type))
  header <- c(
    sprintf("# Hansen (1997, JBES 15, 60-67) p-value response surface for the %sF test,", type),
    sprintf("# from R's strucchange %s (strucchange:::sc.beta.%s),", packageVersion("strucchange"), type),
    "# written by tests/reference/strucchange/hansen_tables.R. Rows: 25 per k = 1 ... 40",
    "# (tau = 0.49, 0.47, ..., 0.01); columns: polynomial coefficients, chi-square df."
  )
  writeLines(header, path)
  # 15 significant digits hold the published values exactly (they have at most 9)
  rows <- apply(unname(as.matrix(beta)), 1, function(row) paste(sprintf("%.15g", row), collapse = " "))
  write(rows, path, append = TRUE)
}
